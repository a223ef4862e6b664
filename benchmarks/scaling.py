"""Guidance and the closed loop at city scale: obstacles x targets on generated cities.

    python benchmarks/scaling.py [--obstacles 0,10,25,50,100] [--targets 1,4,8,16] [--seeds 2]
                                 [--settings c2-soft] [--trials 1] [--steps 50] [--best-known 120]
                                 [--workers 2] [--out runs/scaling] [--resume]
    python benchmarks/scaling.py --report runs/scaling/scaling.json     # the docs' markdown table

City (K, N, s) is ``uavsim world generate --kind city --seed 7919 K + 101 N + s --obstacles K
--targets N``, written to ``OUT/cells`` and read through the mission reader as a user
would.  A setting ``cC-TERM`` runs it with ``filter.plan_clusters = C`` (re-planned every
step, ``filter.motion = "replan"``) and ``guidance.terminal = TERM``.  Per city and setting:

* **first plans** from each target's prior mean, as ``uavsim plan``: seconds, status, gap,
  whether the plan ends in its goal region (and how far out), and, with ``--best-known S``,
  the objective against the best plan found by the same solver given ``S`` nominal seconds
  (its certified lower bound too);
* **the closed loop**: ``--trials`` trials of ``--steps`` steps with the optimized UAV as
  ``uavsim run`` (truth drawn from the prior), recording every guidance plan (the truth's,
  the filter's from the mean and, with two clusters, from each half): seconds, status and
  gap; the step's wall seconds; and the same trials with the **no-information baseline**
  (``uavsim run``'s baseline: no measurements), for each target's time-averaged RMSE;
* **collisions** of every plan by a point-and-segment check against the raw cuboids,
  independent of the solver's inflated faces (``benchmarks/worlds.py``).

Each city's result is kept in ``OUT/cells`` as it finishes (``--resume`` reuses those made
with the same settings); ``OUT/scaling.json`` holds them all, the summary per (K, N,
setting) and the machine (``benchmarks/harness.py``); ``OUT/summary.json`` the summary and
the machine alone (the docs keep that one, ``docs/data/``).  Every trial runs single-threaded;
``--workers`` cities run side by side, one per core.
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from harness import machine, markdown_table, run_cells, write

from uavsim.campaign import one_blas_thread, run_trial, trial_seeds
from uavsim.config import load_mission
from uavsim.guidance import Guidance
from uavsim.sim import Simulation
from uavsim.uav import BASELINE
from uavsim.world.generate import generate, mission_toml, world_toml
from worlds import collisions, goal_distance, quantiles

GAP = 1e-3  # the certified gap the figures count
IN_GOAL_M = 1e-6  # a plan ends in its goal region within this (a hard terminal holds to the QP's tolerance)


def city(k: int, n: int, s: int, folder: Path) -> Path:
    seed = 7919 * k + 101 * n + s
    stem = f"city-k{k}-n{n}-s{s}"
    gen = replace(generate(seed, k, n, kind="city"), name=stem, seed=seed)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / f"{stem}.world.toml").write_text(world_toml(gen))
    (folder / f"{stem}.toml").write_text(mission_toml(gen, f"{stem}.world.toml"))
    return folder / f"{stem}.toml"


def variant(path: Path, setting: str, steps: int, trials: int):
    clusters, terminal = setting[1:].split("-")
    return load_mission(path, {"steps": steps, "trials": max(trials, 1), "filter.motion": "replan",
                               "filter.plan_clusters": int(clusters), "guidance.terminal": terminal})


def first_plans(m, guidance, best_known: float) -> list[dict]:
    long = Guidance(m.world, m.dynamics, replace(m.guidance, time_limit=best_known)) if best_known else None
    out = []
    for t in m.targets:
        goal = m.world.goals[t.goal]
        plan = guidance.plan(t.mean0, t.cov0, goal.centroid)
        row = {"status": plan.status, "objective": plan.objective, "gap": plan.gap, "seconds": plan.solve_seconds,
               "work": plan.work_seconds, "unreachable": plan.unreachable,
               "collisions": collisions(m.world, plan)[0] if plan.ok else 0,
               "end_to_goal_m": goal_distance(m.world, t, plan.positions[-1, :2]) if plan.ok else None}
        if long is not None:
            ref = long.plan(t.mean0, t.cov0, goal.centroid)
            row |= {"best_objective": min(ref.objective, plan.objective), "best_bound": max(ref.lower_bound, 0.0),
                    "best_status": ref.status, "best_gap": ref.gap, "best_seconds": ref.solve_seconds,
                    "best_end_to_goal_m": goal_distance(m.world, t, ref.positions[-1, :2]) if ref.ok else None}
        out.append(row)
    return out


def closed_loop(m, guidance, trials: int) -> dict:
    """``trials`` trials of the optimized UAV and the same trials without measurements:
    every guidance plan's status, gap and seconds, each step's and each reset's seconds,
    collisions of the plans (from their starts, at every step P1 keeps clear) and of the
    truth (every step from the start), and each target's time-averaged RMSE."""
    plans, steps, resets, hits, truth_hits, err2 = [], [], [], 0, 0, []
    with one_blas_thread():
        for seed in trial_seeds(m.seed, trials):
            sim = Simulation(m, "optimized", guidance)
            t0 = time.perf_counter()
            sim.reset(seed)
            resets.append(time.perf_counter() - t0)
            hits += sum(collisions(m.world, p)[0] for p in sim.truth.plans)
            e = []
            for _ in range(m.steps):
                info = sim.step()
                steps.append(info.seconds["total"])
                e.append(((info.mean[:, :2] - info.truth[:, :2]) ** 2).sum(axis=1))
                for p in sim.replans:  # the filter's plans, each from the mean it was made from
                    hits += collisions(m.world, p)[0]
                    plans.append((p.status, p.gap, p.solve_seconds))
            truth_hits += sim.truth.collisions
            err2.append(e)
    base = [run_trial(m, BASELINE, k, seed, guidance).err2 for k, seed in enumerate(trial_seeds(m.seed, trials))]
    status, gap, secs = zip(*plans) if plans else ((), (), ())
    return {"plans": {"status": list(status), "gap": list(gap), "seconds": list(secs)}, "step_seconds": steps,
            "reset_seconds": resets, "collisions": hits, "truth_collisions": truth_hits,
            "rmse": np.sqrt(np.mean(err2, axis=0)).mean(axis=0).tolist(),
            "rmse_baseline": np.sqrt(np.mean(base, axis=0)).mean(axis=0).tolist()}


def run_cell(k: int, n: int, s: int, folder: str, settings: list[str], trials: int, steps: int,
             best_known: float) -> dict:
    with one_blas_thread():
        path = city(k, n, s, Path(folder))
        out = {"obstacles": k, "targets": n, "seed": s, "trials": trials, "steps": steps, "best_known": best_known,
               "settings": {}}
        for setting in settings:
            m = variant(path, setting, steps, trials)
            t0 = time.perf_counter()
            guidance = Guidance(m.world, m.dynamics, m.guidance)
            row = {"first": first_plans(m, guidance, best_known)}
            if trials:
                row |= closed_loop(m, guidance, trials)
            row["wall_seconds"] = time.perf_counter() - t0
            out["settings"][setting] = row
        out["area_m"] = (m.world.area_hi - m.world.area_lo)[:2].tolist()
        cell_path(Path(folder), k, n, s).write_text(json.dumps(out, default=float))
        return out


def cell_path(folder: Path, k: int, n: int, s: int) -> Path:
    return folder / f"city-k{k}-n{n}-s{s}.result.json"


def kept_cell(folder: Path, k, n, s, settings, trials, steps, best_known) -> dict | None:
    try:
        kept = json.loads(cell_path(folder, k, n, s).read_text())
    except (OSError, ValueError):
        return None
    same = (kept["trials"], kept["steps"], kept["best_known"]) == (trials, steps, best_known)
    return kept if same and all(x in kept["settings"] for x in settings) else None


# --------------------------------------------------------------------------- summary
def summarize(cells: list[dict], setting: str) -> dict:
    rows = [c["settings"][setting] for c in cells if setting in c["settings"]]
    first = [f for r in rows for f in r["first"]]
    ok = [f for f in first if f["status"] in ("optimal", "feasible")]
    status = np.array([s for r in rows for s in r.get("plans", {}).get("status", [])])
    gaps = np.array([g for r in rows for g in r.get("plans", {}).get("gap", [])], float)
    secs = [s for r in rows for s in r.get("plans", {}).get("seconds", [])]
    steps = [s for r in rows for s in r.get("step_seconds", [])]
    rmse = np.concatenate([r["rmse"] for r in rows if "rmse" in r]) if steps else np.zeros(0)
    base = np.concatenate([r["rmse_baseline"] for r in rows if "rmse" in r]) if steps else np.zeros(0)
    best = [f["objective"] / f["best_objective"] for f in first if f.get("best_objective", 0) > 1.0]
    proved = [(f["objective"] - f["best_bound"]) / max(f["objective"], 1.0) for f in first if "best_bound" in f]
    return {
        "cities": len(rows), "first_plans": len(first),
        "first_seconds": quantiles([f["seconds"] for f in first]),
        "first_certified": float(np.mean([f["status"] == "optimal" and f["gap"] <= GAP for f in first])) if first
        else None,
        "first_gap": quantiles([f["gap"] for f in ok]),
        "first_in_goal": float(np.mean([f["end_to_goal_m"] <= IN_GOAL_M for f in ok])) if ok else None,
        "first_unreachable": sum(f["unreachable"] for f in first),
        "first_end_to_goal_m_outside": quantiles([f["end_to_goal_m"] for f in ok if f["end_to_goal_m"] > IN_GOAL_M]),
        "first_outside": why_outside([f for f in ok if f["end_to_goal_m"] > IN_GOAL_M]),
        "objective_over_best": quantiles(best), "gap_to_best_bound": quantiles(proved),
        "replans": int(len(status)),
        "replans_certified": float(np.mean(np.isin(status, ("optimal", "feasible")) & (gaps <= GAP)))
        if len(status) else None,
        "replans_fallback": int(np.sum(status == "fallback")), "replan_seconds": quantiles(secs),
        "step_seconds": quantiles(steps) | ({"mean": float(np.mean(steps))} if steps else {}),
        "collisions": int(sum(f["collisions"] for f in first) + sum(r.get("collisions", 0) for r in rows)),
        "truth_collisions": int(sum(r.get("truth_collisions", 0) for r in rows)),
        "reset_seconds": quantiles([s for r in rows for s in r.get("reset_seconds", [])]),
        "rmse_mean": float(rmse.mean()) if len(rmse) else None,
        "rmse_baseline_mean": float(base.mean()) if len(base) else None,
        "rmse_over_baseline": quantiles(rmse / base) if len(rmse) else {},
        "targets_below_baseline": int(np.sum(rmse < base)), "targets": int(len(rmse)),
    }


def why_outside(out: list[dict]) -> dict:
    """First plans ending outside their goal region: how many are certified (then the soft
    terminal term is why: the optimum ends outside), and how many a long run also ends
    outside, certified or not (where it ends inside, the short run had not solved P1)."""
    long = [f for f in out if f.get("best_end_to_goal_m") is not None]
    return {"n": len(out), "certified": sum(f["status"] == "optimal" and f["gap"] <= GAP for f in out),
            "long_run": len(long), "long_run_outside": sum(f["best_end_to_goal_m"] > IN_GOAL_M for f in long),
            "long_run_outside_certified": sum(f["best_end_to_goal_m"] > IN_GOAL_M and f["best_gap"] <= GAP
                                              for f in long)}


def table(summary: list[dict]) -> str:
    """The summary as a markdown table (the docs' scaling page is this, pasted by its command)."""
    def q(d, key, scale=1.0, fmt="{:.2f}"):
        return fmt.format(d[key] * scale) if d and key in d else "-"

    def share(x):
        return "-" if x is None else f"{100 * x:.0f}%"

    head = ["K", "N", "setting", "first s median / max", "first certified", "first gap p90", "in goal",
            "obj / best max", "re-plans", "certified", "re-plan ms p50 / p99", "step s p50 / mean / max", "coll.",
            "RMSE / no-info"]
    rows = []
    for r in summary:
        s = r["summary"]
        rmse = "-" if s["rmse_mean"] is None else (f"{s['rmse_mean']:.1f} / {s['rmse_baseline_mean']:.1f} m "
                                                   f"({s['targets_below_baseline']}/{s['targets']} below)")
        cells = [r["obstacles"], r["targets"], r["setting"],
                 f"{q(s['first_seconds'], 'median')} / {q(s['first_seconds'], 'max')}", share(s["first_certified"]),
                 q(s["first_gap"], "p90", fmt="{:.1e}"), share(s["first_in_goal"]),
                 q(s["objective_over_best"], "max", fmt="{:.3f}"), s["replans"], share(s["replans_certified"]),
                 f"{q(s['replan_seconds'], 'median', 1e3, '{:.1f}')} / {q(s['replan_seconds'], 'p99', 1e3, '{:.0f}')}",
                 f"{q(s['step_seconds'], 'median')} / {q(s['step_seconds'], 'mean')} / {q(s['step_seconds'], 'max')}",
                 s["collisions"], rmse]
        rows.append(cells)
    return markdown_table(head, rows)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--obstacles", default="0,10,25,50,100")
    ap.add_argument("--targets", default="1,4,8,16")
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--settings", default="c2-soft", help="comma-separated cC-TERM: plan_clusters C, terminal TERM")
    ap.add_argument("--trials", type=int, default=1)
    ap.add_argument("--steps", type=int, default=50)
    ap.add_argument("--best-known", type=float, default=0.0, metavar="S",
                    help="nominal seconds of the long run each first plan is compared with (0: none)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default="runs/scaling")
    ap.add_argument("--resume", action="store_true")
    ap.add_argument("--report", metavar="JSON", help="print the markdown table of a finished run and stop")
    args = ap.parse_args()
    if args.report:
        print(table(json.loads(Path(args.report).read_text())["summary"]))
        return
    started = machine()
    ks, ns = [int(x) for x in args.obstacles.split(",")], [int(x) for x in args.targets.split(",")]
    settings = args.settings.split(",")
    out, cells_dir = Path(args.out), Path(args.out) / "cells"
    grid = [(k, n, s) for k in ks for n in ns for s in range(args.seeds)]
    cfg = (settings, args.trials, args.steps, args.best_known)
    kept = {c: kept_cell(cells_dir, *c, *cfg) for c in grid} if args.resume else {}
    todo = [c for c in grid if kept.get(c) is None]
    print(f"{len(grid) - len(todo)} cities kept, {len(todo)} to run", flush=True)
    kept |= run_cells(run_cell, todo, (str(cells_dir), *cfg), args.workers, "city")
    cells = [kept[c] for c in grid if kept.get(c) is not None]
    summary = [{"obstacles": k, "targets": n, "setting": x,
                "summary": summarize([c for c in cells if (c["obstacles"], c["targets"]) == (k, n)], x)}
               for k in ks for n in ns for x in settings]
    summary += [{"obstacles": "all", "targets": "all", "setting": x, "summary": summarize(cells, x)} for x in settings]
    write(out / "scaling.json", {"settings": vars(args), "summary": summary, "cells": cells}, started)
    write(out / "summary.json", {"settings": vars(args), "summary": summary}, started)
    print(table(summary))
    print(f"wrote {out / 'scaling.json'} and {out / 'summary.json'} (the figures without the per-plan records)")


if __name__ == "__main__":
    main()
