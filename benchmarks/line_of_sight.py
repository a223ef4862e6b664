"""What line of sight costs: the UAV's decision (Eq. 12-13) and the filter's update with and without it.

    python benchmarks/line_of_sight.py [--worlds osm-small,osm-medium] [--targets 8] [--particles 5000]
                                       [--steps 5] [--repeats 30] [--json PATH]

Each world is imported as ``benchmarks/towns.py`` imports it (its mission has ``[sensor]
line_of_sight = true``) and flown for ``--steps`` steps, so the clouds and the UAV are where a
mission puts them.  Then, on that predicted belief, the decision's traces for every grid move
(:meth:`uavsim.belief.Belief.traces`) and one scan's likelihood for every particle
(:meth:`uavsim.sensing.BearingModel.log_likelihood`) are timed with the mission's sensor and
with the same sensor less line of sight, interleaved, ``--repeats`` times each (medians, one
BLAS thread).  The aim: the decision with line of sight at most twice its cost
without.
"""

from __future__ import annotations

import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from harness import parser, run
from towns import mission_file

from uavsim.config import load_mission
from uavsim.sim import Simulation


def seconds(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def one_world(world: str, n: int, particles: int, steps: int, repeats: int) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        m = load_mission(mission_file(world, n, Path(tmp)), {"filter.particles": particles})
    on, off = m.sensor, replace(m.sensor, line_of_sight=False, world=None)
    sim = Simulation(m, "optimized")
    sim.reset(np.random.SeedSequence(m.seed).spawn(1)[0])
    for _ in range(steps):
        sim.step()
    sim.prepare()  # the predicted belief the UAV decides on
    cands, ok = sim.policy.moves()
    cands = cands[ok]
    scan = on.draw(np.random.default_rng(0), sim.truth.state[:, :3], sim.policy.position)
    parts = sim.belief.pf.particles
    row = {"world": world, "targets": n, "particles": particles, "obstacles": m.world.n_obstacles,
           "candidates": len(cands)}
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
    hidden = ~on.visible(sim.truth.state[:, :3], sim.policy.position)
    row["targets_hidden_now"] = int(hidden.sum())
    print(f"{world} ({row['obstacles']} obstacles, {n} targets x {particles} particles, {len(cands)} moves): "
          f"decision {row['decide_ms_off']:.1f} ms without line of sight, {row['decide_ms_on']:.1f} ms with "
          f"(x{row['decide_ratio']:.2f}); update {row['update_ms_off']:.1f} / {row['update_ms_on']:.1f} ms "
          f"(x{row['update_ratio']:.2f}); {row['targets_hidden_now']} targets hidden now", flush=True)
    return row


def main(args) -> dict:
    rows = [one_world(w, args.targets, args.particles, args.steps, args.repeats) for w in args.worlds.split(",")]
    return {"rows": rows}


if __name__ == "__main__":
    ap = parser(__doc__)
    ap.add_argument("--worlds", default="osm-small,osm-medium")
    ap.add_argument("--targets", type=int, default=8)
    ap.add_argument("--particles", type=int, default=5000)
    ap.add_argument("--steps", type=int, default=5)
    ap.add_argument("--repeats", type=int, default=30)
    run(main, ap)
