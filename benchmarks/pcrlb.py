"""The closed-loop PCRLB beside the measured RMSE on a mission, and what the bound costs.

    python benchmarks/pcrlb.py [--mission missions/paper.toml] [--planner optimized,...] [--trials 20]
                               [--truth planned,stochastic] [--every 5] [--workers N] [--out runs/pcrlb]

For each planner and truth (comma-separated lists; default: the mission's truth), runs trials
0..n-1 of the mission (its seed) as a campaign (trial files keep the truth, the
sensor path and the planned truth's sensitivity) and prints: the IRF of the sensor (and of
Lambda = 0, 1, 8), per step the trials' RMSE ([Papaioannou2023, Sec. VI-B], averaged over targets) beside
the campaign's bound (``pcrlb_planned`` for a planned truth) and beside the recursion of
the mission's model (A, Q, controls as known inputs; ``pcrlb_for_trials``), which the
simulator's truths do not follow (their controls answer their own state): with no sensor
the prediction's RMSE falls below that recursion, so it is no floor.  Run it with
OPENBLAS_NUM_THREADS=1.

The trials' RMSE is a sample of ``trials`` squared errors per step and target: with 20
trials its relative standard error is about 8% per step (4 targets, Gaussian errors), so a
single step's ratio says little; time averages and the share of steps below 1 say more.
"""

from __future__ import annotations

import os
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from harness import parser, run

from uavsim.bounds.pcrlb import _q2_quadrature, information_reduction_factor, pcrlb_for_trials, pcrlb_planned
from uavsim.campaign import load_trials, run_campaign
from uavsim.config import load_mission
from uavsim.metrics import consistency
from uavsim.uav.fixed import fixed_sensor


def irf_table(sigma: float, p_detect: float, rate: float) -> dict:
    print(f"{'sigma deg':>10}{'p_D':>6}{'Lambda':>8}{'q2':>12}{'q2 / p_D':>10}")
    rows = []
    for lam in sorted({0.0, 1.0, 8.0, rate}):
        q2 = information_reduction_factor(sigma, p_detect, lam)
        print(f"{np.degrees(sigma):10.2f}{p_detect:6.2f}{lam:8.2f}{q2:12.6f}{q2 / p_detect if p_detect else 0:10.4f}")
        rows.append({"sigma_deg": float(np.degrees(sigma)), "p_detect": p_detect, "clutter_rate": lam, "q2": q2})
    lu = 8.0 * sigma / (2 * np.pi)
    t0 = time.perf_counter()
    for _ in range(20):
        _q2_quadrature(lu, p_detect, np.pi / sigma)
    ms = 1e3 * (time.perf_counter() - t0) / 20
    print(f"IRF quadrature (uncached): {ms:.1f} ms")
    return {"irf": rows, "irf_quadrature_ms": ms}


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--mission", default="missions/paper.toml")
    ap.add_argument("--planner", default="optimized", help="comma-separated planners")
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--truth", default=None, help="comma-separated: planned, stochastic (default: the mission's)")
    ap.add_argument("--every", type=int, default=5, help="print every k-th step")
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--out", default="runs/pcrlb")
    run(measure, ap)


def measure(args) -> dict:
    """The benchmark proper, on the parsed arguments (``harness.run`` records what it prints
    and the figures returned: per ``planner/truth`` the time averages and the per-step series)."""
    mission = load_mission(args.mission, {"trials": args.trials})
    figures = {"campaigns": {}}
    for truth in (args.truth or mission.truth).split(","):
        for planner in args.planner.split(","):
            print(f"\n==== {planner}, truth {truth}")
            figures["campaigns"][f"{planner}/{truth}"] = campaign(args, replace(mission, truth=truth), planner, figures)
    return figures


def campaign(args, mission, planner: str, figures: dict) -> dict:
    """One planner's campaign on ``mission``: prints its table, returns its figures (and puts
    the sensor's IRF table in ``figures`` the first time it is printed for that sensor)."""
    sensor = fixed_sensor(mission) if planner == "fixed-sensors" else mission.sensor
    irf = figures.setdefault("irf", {})
    if (kind := "fixed-sensors" if planner == "fixed-sensors" else "uav") not in irf:
        irf[kind] = irf_table(sensor.sigma, sensor.p_detect, sensor.clutter_rate)
    folder = Path(args.out) / f"{Path(args.mission).stem}-{mission.truth}-{planner}"
    summary = run_campaign(mission, planner, out=folder, workers=args.workers, resume=True)
    trials = load_trials(folder / "trials", range(args.trials))
    truth = np.stack([trials[k].truth for k in range(args.trials)])
    observers = np.stack([trials[k].observers for k in range(args.trials)])
    cov0 = np.array([t.cov0 for t in mission.targets])
    rmse = np.array(summary["rmse"])
    model = pcrlb_for_trials(truth, observers, mission.dynamics, cov0, sensor).pos
    blind = pcrlb_for_trials(truth, observers[:, :, :0], mission.dynamics, cov0, sensor).pos
    if mission.truth == "planned":
        sens = np.stack([trials[k].sensitivity for k in range(args.trials)])
        t1 = time.perf_counter()
        bound = pcrlb_planned(sens, truth, observers, cov0, sensor).pos
        secs = time.perf_counter() - t1
    else:
        bound, secs = np.full_like(rmse, np.nan), 0.0
    print(f"\n{planner} on {mission.path} (truth {mission.truth}): {args.trials} trials x {mission.steps} steps "
          f"in {summary['wall_seconds']:.0f} s (0 if resumed)")
    print("PCRLB: the campaign's bound (planned truth); model: the recursion with Q and known controls; "
          "model, no sensor: its prediction alone")
    print(f"{'step':>5}{'RMSE m':>10}{'PCRLB m':>10}{'RMSE/PCRLB':>12}{'model m':>10}{'model, no sensor m':>20}")
    for t in [*range(args.every - 1, mission.steps, args.every)]:
        print(f"{t + 1:5d}{rmse[t]:10.2f}{bound[t]:10.2f}{rmse[t] / bound[t]:12.2f}{model[t]:10.2f}{blind[t]:20.2f}")
    print(f"{'mean':>5}{rmse.mean():10.2f}{bound.mean():10.2f}{rmse.mean() / bound.mean():12.2f}"
          f"{model.mean():10.2f}{blind.mean():20.2f}")
    for name, b in (("PCRLB", bound), ("model", model)):
        ratio = rmse / b
        print(f"RMSE / {name} over all {mission.steps} steps: min {np.nanmin(ratio):.2f}, median "
              f"{np.nanmedian(ratio):.2f}, steps below 1: {int((ratio < 1).sum())}")
    print(f"bound of {args.trials} trials x {mission.steps} steps x {len(mission.targets)} targets: "
          f"{1e3 * secs:.1f} ms (IRF cached)")
    nees = consistency(np.stack([trials[k].nees_pos for k in range(args.trials)]), 2)
    print(f"position NEES: mean {np.mean(nees['mean']):.2f} (expected 2), inside its 95% band at "
          f"{nees['inside']:.0%} of steps, below at {nees['below']:.0%}, above at {nees['above']:.0%}")
    finite = np.isfinite(bound)
    return {"trials": args.trials, "rmse": rmse.tolist(),
            "pcrlb": [float(b) if f else None for b, f in zip(bound, finite)],
            "model": model.tolist(), "model_no_sensor": blind.tolist(), "time_avg_rmse": float(rmse.mean()),
            "time_avg_pcrlb": float(bound.mean()) if finite.all() else None, "time_avg_model": float(model.mean()),
            "time_avg_model_no_sensor": float(blind.mean()), "bound_ms": 1e3 * secs,
            "nees_mean": float(np.mean(nees["mean"])), "nees_inside": nees["inside"], "nees_below": nees["below"]}


if __name__ == "__main__":
    main()
