"""Guidance and the closed loop in towns: crops of central Helsinki imported from OpenStreetMap, generated towns.

    python benchmarks/towns.py [--worlds osm-small,osm-medium,...,grid,osm-medium:16,town-100:16,city-100:16]
                               [--targets 8] [--trials 2] [--steps 20] [--truth-trials 30]
                               [--setting c1-soft] [--workers 2] [--out runs/towns] [--resume]
    python benchmarks/towns.py --report runs/towns/towns.json     # the docs' markdown table

A world is ``osm-CROP`` (a crop of worlds/osm/helsinki-centre.osm.pbf, ODbL, through
``uavsim world import --targets N --seed 1 --reach 0.1,0.9``: ``small`` 50 buildings, ``station`` 86,
``helsinki`` 133, ``medium`` 150, ``large`` 400; see ``benchmarks/osm_import.py``),
``town-K`` (``uavsim world generate --kind town --obstacles K --targets N``: irregular blocks,
buildings off the axes, goals 0.9-1.0 of the horizon's reach away), ``city-K`` (``--kind
city``: the street grids, goals at most 0.6 of the reach away) or ``grid`` (the
street grid drawn by hand, benchmarks/towns/grid.toml, with its own six targets).  Each
runs with ``--setting`` (``cC-TERM``: ``filter.plan_clusters = C``, ``guidance.terminal =
TERM``) and the mission's own budgets and gap, and measures (:mod:`benchmarks.scaling`):

* **first plans** from each target's prior mean: seconds, status, certified gap, in goal;
* **the closed loop**, ``--trials`` trials of ``--steps`` steps with the optimized UAV:
  every re-plan's status, gap and seconds, each step's and each reset's wall seconds,
  collisions of the plans (from their starts, at every step P1 keeps clear) and of the
  truth, and each target's time-averaged RMSE against the same trials without
  measurements;
* **the truth alone**, ``--truth-trials`` draws and runs of the true targets (no filter,
  no UAV): truth steps that touch an obstacle, every step from the start
  (:attr:`uavsim.truth.Truth.collisions`), and reset seconds.

Each world's result is kept in ``OUT/cells`` as it finishes (``--resume`` reuses those
made with the same settings); ``OUT/towns.json`` holds them all with the summary and the
machine; ``--json`` writes the summary alone (the docs keep that one).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
from harness import ROOT, machine, markdown_table, run_cells, write
from osm_import import CROPS
from scaling import closed_loop, first_plans, variant

from uavsim.campaign import one_blas_thread, trial_seeds
from uavsim.cli import main as cli
from uavsim.guidance import Guidance
from uavsim.sim import Simulation
from worlds import quantiles

PBF = ROOT / "worlds" / "osm" / "helsinki-centre.osm.pbf"


def mission_file(world: str, n: int, folder: Path) -> Path:
    """The mission of a named world with ``n`` targets, written to ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    if world == "grid":
        return ROOT / "benchmarks" / "towns" / "grid.toml"
    out = folder / f"{world}-n{n}.toml"
    if world.startswith("osm-"):
        box = ",".join(map(str, CROPS[world[4:]]))
        code = cli(["world", "import", str(PBF), "--bbox", box, "--targets", str(n), "--seed", "1", "--reach",
                    "0.1,0.9", "--out", str(out), "--force"])
    else:
        kind, k = world.split("-")[0], int(world.split("-")[1])
        code = cli(["world", "generate", "--kind", kind, "--seed", str(7919 * k + 101 * n), "--obstacles", str(k),
                    "--targets", str(n), "--out", str(out), "--force"])
    if code:
        raise RuntimeError(f"could not make {world} with {n} targets")
    return out


def truth_alone(m, guidance, trials: int) -> dict:
    """``trials`` draws of the true targets run through the mission without a filter or a
    UAV: their steps that touch an obstacle, and the seconds of each reset."""
    hits, resets = 0, []
    with one_blas_thread():
        sim = Simulation(m, "baseline", guidance)
        for seed in trial_seeds(m.seed, trials):
            t0 = time.perf_counter()
            sim.reset(seed)
            resets.append(time.perf_counter() - t0)
            truth, events = sim.truth, []
            for t in range(m.steps):
                truth.move(t, truth.controls(t, events))
            hits += truth.collisions
    return {"truth_trials": trials, "truth_steps": trials * m.steps * len(m.targets), "truth_collisions": hits,
            "truth_reset_seconds": resets}


def run_world(world: str, n: int, folder: str, setting: str, trials: int, steps: int, truth_trials: int) -> dict:
    with one_blas_thread():
        path = mission_file(world, n, Path(folder))
        m = variant(path, setting, steps, trials)
        t0 = time.perf_counter()
        guidance = Guidance(m.world, m.dynamics, m.guidance)
        out = {"world": world, "targets": len(m.targets), "buildings": m.world.n_obstacles, "setting": setting,
               "trials": trials, "steps": steps, "truth_trials_asked": truth_trials, "gap": m.guidance.gap,
               "area_m": (m.world.area_hi - m.world.area_lo)[:2].tolist(), "first": first_plans(m, guidance, 0.0)}
        if trials:
            out |= closed_loop(m, guidance, trials)
        if truth_trials:
            out |= truth_alone(m, guidance, truth_trials)
        out["wall_seconds"] = time.perf_counter() - t0
        cell_path(Path(folder), world, n).write_text(json.dumps(out, default=float))
        return out


def cell_path(folder: Path, world: str, n: int) -> Path:
    return folder / f"{world}-n{n}.result.json"


def kept_cell(folder: Path, world: str, n: int, setting, trials, steps, truth_trials) -> dict | None:
    try:
        kept = json.loads(cell_path(folder, world, n).read_text())
    except (OSError, ValueError):
        return None
    same = (kept["setting"], kept["trials"], kept["steps"], kept["truth_trials_asked"]) == (setting, trials, steps,
                                                                                           truth_trials)
    return kept if same else None


def summarize(cell: dict) -> dict:
    """One world's figures: first plans and re-plans certified (at the mission's gap, and
    first plans at 0.05), their seconds, steps, resets, collisions, RMSE against no
    information."""
    first = cell["first"]
    ok = [f for f in first if f["status"] in ("optimal", "feasible")]
    status = np.array(cell.get("plans", {}).get("status", []))
    rmse, base = np.array(cell.get("rmse", [])), np.array(cell.get("rmse_baseline", []))
    return {
        "first_seconds": quantiles([f["seconds"] for f in first]),
        "first_certified": float(np.mean([f["status"] == "optimal" for f in first])),
        "first_within_5pc": float(np.mean([f["status"] in ("optimal", "feasible") and f["gap"] <= 0.05
                                           for f in first])),
        "first_gap": quantiles([f["gap"] for f in ok]),
        "first_in_goal": float(np.mean([f["end_to_goal_m"] <= 1e-6 for f in ok])) if ok else None,
        "replans": int(len(status)),
        "replans_certified": float(np.mean(status == "optimal")) if len(status) else None,
        "replan_gap": quantiles(cell.get("plans", {}).get("gap", [])),
        "replan_seconds": quantiles(cell.get("plans", {}).get("seconds", [])),
        "step_seconds": quantiles(cell.get("step_seconds", [])),
        "reset_seconds": quantiles(cell.get("reset_seconds", []) + cell.get("truth_reset_seconds", [])),
        "plan_collisions": int(cell.get("collisions", 0) + sum(f["collisions"] for f in first)),
        "truth_collisions": int(cell.get("truth_collisions", 0)),
        "truth_steps_checked": int(cell.get("truth_steps", 0) + cell.get("trials", 0) * cell.get("steps", 0)
                                   * cell["targets"]),
        "rmse_over_baseline": float(rmse.mean() / base.mean()) if len(rmse) else None,
        "targets_below_baseline": int(np.sum(rmse < base)),
    }


def table(cells: list[dict]) -> str:
    def q(d, key, scale=1.0, fmt="{:.2f}"):
        return fmt.format(d[key] * scale) if d and key in d else "-"

    def share(x):
        return "-" if x is None else f"{100 * x:.0f}%"

    head = ["world", "buildings", "targets", "first s p50 / max", "first certified (gap <= 0.05)", "first gap p90",
            "in goal", "re-plans", "certified", "re-plan gap p90", "re-plan ms p50 / p99", "step s p50 / max",
            "reset s p50 / max", "truth collisions (steps checked)", "plan collisions", "RMSE / no-info"]
    rows = []
    for c in cells:
        s = c["summary"]
        rmse = "-" if s["rmse_over_baseline"] is None else (f"{s['rmse_over_baseline']:.2f} "
                                                            f"({s['targets_below_baseline']}/{c['targets']} below)")
        rows.append([c["world"], c["buildings"], c["targets"],
                     f"{q(s['first_seconds'], 'median')} / {q(s['first_seconds'], 'max')}",
                     f"{share(s['first_certified'])} ({share(s['first_within_5pc'])})",
                     q(s["first_gap"], "p90", fmt="{:.1e}"), share(s["first_in_goal"]), s["replans"],
                     share(s["replans_certified"]), q(s["replan_gap"], "p90", fmt="{:.1e}"),
                     f"{q(s['replan_seconds'], 'median', 1e3, '{:.0f}')} / "
                     f"{q(s['replan_seconds'], 'p99', 1e3, '{:.0f}')}",
                     f"{q(s['step_seconds'], 'median')} / {q(s['step_seconds'], 'max')}",
                     f"{q(s['reset_seconds'], 'median')} / {q(s['reset_seconds'], 'max')}",
                     f"{s['truth_collisions']} ({s['truth_steps_checked']})", s["plan_collisions"], rmse])
    return markdown_table(head, rows)


def world_cells(worlds: str, targets: str) -> list[tuple[str, int]]:
    """``(world, targets)`` of ``--worlds`` (``NAME`` with each of ``--targets``, or
    ``NAME:N``), the grid with its own six."""
    out = []
    for w in worlds.split(","):
        name, _, n = w.partition(":")
        out += [(name, 6 if name == "grid" else int(k)) for k in (n or targets).split(",")]
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--worlds", default="osm-small,osm-medium,osm-large,town-50,town-100,grid,osm-medium:16,"
                                        "town-100:16,city-100:16",
                    help="NAME (with --targets) or NAME:N, comma-separated")
    ap.add_argument("--targets", default="8", help="comma-separated target counts (the grid keeps its six)")
    ap.add_argument("--setting", default="c1-soft", help="cC-TERM: plan_clusters C, terminal TERM")
    ap.add_argument("--trials", type=int, default=2)
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--truth-trials", type=int, default=30)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default="runs/towns")
    ap.add_argument("--resume", action="store_true")
    ap.add_argument("--json", metavar="PATH", help="also write the summary and the machine here (the docs' copy)")
    ap.add_argument("--report", metavar="JSON", help="print the markdown table of a finished run and stop")
    args = ap.parse_args()
    if args.report:
        print(table(json.loads(Path(args.report).read_text())["cells"]))
        return
    started = machine()
    cells_dir = Path(args.out) / "cells"
    grid = list(dict.fromkeys(world_cells(args.worlds, args.targets)))
    cfg = (args.setting, args.trials, args.steps, args.truth_trials)
    kept = {c: kept_cell(cells_dir, *c, *cfg) for c in grid} if args.resume else {}
    todo = [c for c in grid if kept.get(c) is None]
    print(f"{len(grid) - len(todo)} worlds kept, {len(todo)} to run", flush=True)
    kept |= run_cells(run_world, todo, (str(cells_dir), *cfg), args.workers, "world")
    cells = [kept[c] | {"summary": summarize(kept[c])} for c in grid if kept.get(c) is not None]
    slim = [{k: v for k, v in c.items() if k in ("world", "targets", "buildings", "setting", "trials", "steps",
                                                  "area_m", "gap", "summary")} for c in cells]
    write(Path(args.out) / "towns.json", {"settings": vars(args), "cells": cells}, started)
    if args.json:
        write(Path(args.json), {"settings": vars(args), "cells": slim}, started)
    print(table(cells))


if __name__ == "__main__":
    main()
