"""What line of sight costs: the UAV's decision (Eq. 12-13) and the filter's update with and without it.

    python benchmarks/line_of_sight.py [--worlds osm-small,osm-medium,city-100] [--targets 8]
                                       [--particles 5000] [--at 5,10,15] [--repeats 30] [--json PATH]

Each world is made as ``benchmarks/towns.py`` makes it, with ``[sensor] line_of_sight = true``
(an imported town's mission has it; a generated city's is turned on), and flown; at each step
of ``--at`` the clouds and the UAV are where a mission puts them.  Then, on that predicted
belief, the decision's traces for every grid move
(:meth:`uavsim.belief.Belief.traces`) and one scan's likelihood for every particle
(:meth:`uavsim.sensing.BearingModel.log_likelihood`) are timed with the mission's sensor and
with the same sensor less line of sight, interleaved, ``--repeats`` times each (medians, one
BLAS thread).  The aim: the decision with line of sight at most twice its cost
without.  At each state the decision's traces (a cloud's cells each take one verdict) are also
compared with the exact mix, every particle's line of sight tested.
"""

from __future__ import annotations

import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from harness import parser, run
from towns import mission_file

from uavsim.belief import traces
from uavsim.config import load_mission
from uavsim.sim import Simulation


def seconds(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def one_world(world: str, n: int, particles: int, at: list[int], repeats: int) -> list[dict]:
    with tempfile.TemporaryDirectory() as tmp:
        m = load_mission(mission_file(world, n, Path(tmp)), {"filter.particles": particles,
                                                             "sensor.line_of_sight": True})
    on, off = m.sensor, replace(m.sensor, line_of_sight=False, world=None)
    sim = Simulation(m, "optimized")
    sim.reset(np.random.SeedSequence(m.seed).spawn(1)[0])
    rows = []
    for step in range(1, max(at) + 1):
        sim.step()
        if step in at:
            rows.append(one_state(sim, on, off, repeats) | {"world": world, "step": step, "targets": n,
                                                            "particles": particles, "obstacles": m.world.n_obstacles})
            r = rows[-1]
            print(f"{world} ({r['obstacles']} obstacles, {n} targets x {particles} particles) after {step} steps, "
                  f"{r['candidates']} moves: decision {r['decide_ms_off']:.1f} ms without line of sight, "
                  f"{r['decide_ms_on']:.1f} ms with (x{r['decide_ratio']:.2f}); update {r['update_ms_off']:.1f} / "
                  f"{r['update_ms_on']:.1f} ms (x{r['update_ratio']:.2f}); {r['targets_hidden_now']} targets hidden "
                  f"now; traces by cells against every particle's line of sight: error median "
                  f"{r['trace_error_median']:.1e}, largest {r['trace_error_max']:.2f}, "
                  f"{'the same move' if r['same_move'] else 'another move'} (+{100 * r['score_loss']:.2f}%)",
                  flush=True)
    return rows


def one_state(sim: Simulation, on, off, repeats: int) -> dict:
    """The decision's and the update's times with and without line of sight, interleaved."""
    sim.prepare()  # the predicted belief the UAV decides on
    cands, ok = sim.policy.moves()
    cands = cands[ok]
    scan = on.draw(np.random.default_rng(0), sim.truth.state[:, :3], sim.policy.position)
    parts = sim.belief.pf.particles
    row = {"candidates": len(cands)}
    for sensor in (off, on):  # warm both up (first calls allocate)
        sim.belief.traces(cands, sensor)
        sensor.log_likelihood(scan, parts, sim.policy.position)
    decide = {"off": [], "on": []}
    update = {"off": [], "on": []}
    for r in range(repeats):
        for name, sensor in ((("off", off), ("on", on)) if r % 2 else (("on", on), ("off", off))):
            decide[name].append(seconds(lambda s=sensor: sim.belief.traces(cands, s)))
            update[name].append(seconds(lambda s=sensor: s.log_likelihood(scan, parts, sim.policy.position)))
    for k in ("off", "on"):
        row[f"decide_ms_{k}"] = 1e3 * float(np.median(decide[k]))
        row[f"update_ms_{k}"] = 1e3 * float(np.median(update[k]))
    row["decide_ratio"] = row["decide_ms_on"] / row["decide_ms_off"]
    row["update_ratio"] = row["update_ms_on"] / row["update_ms_off"]
    row["targets_hidden_now"] = int((~on.visible(sim.truth.state[:, :3], sim.policy.position)).sum())
    return row | against_exact(cands, sim.belief.pf.particles, sim.belief.pf.weights, on)


def against_exact(cands: np.ndarray, particles: np.ndarray, weights: np.ndarray, sensor) -> dict:
    """The decision's traces by cells against the exact mix, every particle's line of sight
    tested (``model_traces`` with no thinning): the median and largest relative error of
    the (move, target) traces, whether the best move is the same, and how much larger the
    exact summed trace of the move taken is than the best (0 when the same)."""
    exact = traces.model_traces(cands, particles, weights, sensor, keep=particles.shape[1])
    cells = traces.pseudo_traces(cands, particles, weights, sensor)
    err = np.abs(cells / exact - 1.0)
    total = exact.sum(axis=1)
    taken = int(np.argmin(cells.sum(axis=1)))
    return {"trace_error_median": float(np.median(err)), "trace_error_max": float(err.max()),
            "same_move": bool(taken == int(np.argmin(total))), "score_loss": float(total[taken] / total.min() - 1.0)}


def main(args) -> dict:
    at = sorted(int(t) for t in args.at.split(","))
    rows = [r for w in args.worlds.split(",") for r in one_world(w, args.targets, args.particles, at, args.repeats)]
    return {"rows": rows}


if __name__ == "__main__":
    ap = parser(__doc__)
    ap.add_argument("--worlds", default="osm-small,osm-medium,city-100")
    ap.add_argument("--targets", type=int, default=8)
    ap.add_argument("--particles", type=int, default=5000)
    ap.add_argument("--at", default="5,10,15", help="the steps after which to time, comma-separated")
    ap.add_argument("--repeats", type=int, default=30)
    run(main, ap)
