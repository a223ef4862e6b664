"""The closed-loop PCRLB beside the measured RMSE on a mission, and what the bound costs.

    python benchmarks/pcrlb.py [--mission missions/paper.toml] [--planner optimized] [--trials 5]
                               [--truth planned|stochastic] [--every 5]

Runs trials 0..n-1 of the mission (its seed), collects every step's truth and sensor
positions through ``run_trial(on_step=...)``, and prints: the IRF of the mission's sensor
(and of the paper's Lambda = 1 and 8), the bound per step beside the trials' RMSE (004
Sec. VI-B, averaged over targets), the same bound with Q = 0 (a noise-free truth, as
``truth = "planned"`` flies) and the no-sensor prediction bound, time averages, and the
seconds the IRF quadrature and the bound take.  Run it with OPENBLAS_NUM_THREADS=1.

The trials' RMSE is a sample of ``trials`` squared errors per step and target: with 10
trials its relative standard error is about 20% for Gaussian errors, so a single step's
ratio says little; the time averages and the share of steps below 1 say more.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

import numpy as np

from uavsim import metrics
from uavsim.campaign import run_trial, trial_seeds
from uavsim.config import load_mission
from uavsim.guidance import Guidance
from uavsim.pcrlb import _q2_quadrature, information_reduction_factor, pcrlb_for_trials


def _collector(steps: list):
    """An ``on_step`` keeping (truth, observers) of steps 1..T (the reset's step 0 has no scan)."""
    return lambda info: steps.append((info.truth, info.observers)) if info.t else None


def run(mission, planner: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per trial: truth (T, M, 6), observers (T, S, 3), squared errors (T, M)."""
    guidance = Guidance(mission.world, mission.dynamics, mission.guidance)
    truth, observers, err2 = [], [], []
    for k, seed in enumerate(trial_seeds(mission.seed, mission.trials)):
        steps: list[tuple[np.ndarray, np.ndarray]] = []
        result = run_trial(mission, planner, k, seed, guidance, on_step=_collector(steps))
        truth.append([s[0] for s in steps])
        observers.append([s[1] for s in steps])
        err2.append(result.err2)
    return np.array(truth), np.array(observers), np.array(err2)


def irf_table(sigma: float, p_detect: float, rate: float) -> None:
    print(f"{'sigma deg':>10}{'p_D':>6}{'Lambda':>8}{'q2':>12}{'q2 / p_D':>10}")
    for lam in sorted({0.0, 1.0, 8.0, rate}):
        q2 = information_reduction_factor(sigma, p_detect, lam)
        print(f"{np.degrees(sigma):10.2f}{p_detect:6.2f}{lam:8.2f}{q2:12.6f}{q2 / p_detect if p_detect else 0:10.4f}")
    lu = 8.0 * sigma / (2 * np.pi)
    t0 = time.perf_counter()
    for _ in range(20):
        _q2_quadrature(lu, p_detect, np.pi / sigma)
    print(f"IRF quadrature (uncached): {1e3 * (time.perf_counter() - t0) / 20:.1f} ms")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mission", default="missions/paper.toml")
    ap.add_argument("--planner", default="optimized")
    ap.add_argument("--trials", type=int, default=5)
    ap.add_argument("--truth", choices=("planned", "stochastic"), default=None)
    ap.add_argument("--every", type=int, default=5, help="print every k-th step")
    args = ap.parse_args()
    mission = load_mission(args.mission, {"trials": args.trials})
    if args.truth:
        mission = replace(mission, truth=args.truth)
    fixed = args.planner == "fixed-sensors"
    sensor = mission.planner.fixed_sensors.sensor if fixed else mission.sensor
    irf_table(sensor.sigma, sensor.p_detect, sensor.clutter_rate)

    t0 = time.perf_counter()
    truth, observers, err2 = run(mission, args.planner)
    wall = time.perf_counter() - t0
    cov0 = np.array([t.cov0 for t in mission.targets])
    t1 = time.perf_counter()
    bound = pcrlb_for_trials(truth, observers, mission.dynamics, cov0, sensor)
    secs = time.perf_counter() - t1
    blind = pcrlb_for_trials(truth, observers[:, :, :0], mission.dynamics, cov0, sensor)
    noise_free = pcrlb_for_trials(truth, observers, replace(mission.dynamics, q=np.zeros((6, 6))), cov0, sensor)
    rmse = metrics.rmse_per_target(err2).mean(axis=0)

    print(f"\n{args.planner} on {mission.path} (truth {mission.truth}): {args.trials} trials x {mission.steps} steps "
          f"in {wall:.0f} s; q2 = {bound.q2:.6f}")
    print("PCRLB: the mission's model (Q); Q = 0: the same with no process noise (known controls); "
          "no sensor: the prediction alone")
    print(f"{'step':>5}{'RMSE m':>10}{'PCRLB m':>10}{'RMSE/PCRLB':>12}{'Q = 0 m':>10}{'no sensor m':>13}")
    for t in [*range(args.every - 1, mission.steps, args.every)]:
        print(f"{t + 1:5d}{rmse[t]:10.2f}{bound.pos[t]:10.2f}{rmse[t] / bound.pos[t]:12.2f}"
              f"{noise_free.pos[t]:10.2f}{blind.pos[t]:13.2f}")
    print(f"{'mean':>5}{rmse.mean():10.2f}{bound.pos.mean():10.2f}{rmse.mean() / bound.pos.mean():12.2f}"
          f"{noise_free.pos.mean():10.2f}{blind.pos.mean():13.2f}")
    ratio = rmse / bound.pos
    print(f"RMSE / PCRLB over all {mission.steps} steps: min {ratio.min():.2f} (step {ratio.argmin() + 1}), "
          f"median {np.median(ratio):.2f}, steps below 1: {int((ratio < 1).sum())}")
    per = metrics.rmse_per_target(err2).mean(axis=1)
    print("time-averaged per target (RMSE / PCRLB m): " + ", ".join(
        f"{t.name} {r:.2f} / {b:.2f}" for t, r, b in zip(mission.targets, per, bound.pos_per_target.mean(axis=1))))
    print(f"bound of {args.trials} trials x {mission.steps} steps x {len(mission.targets)} targets: "
          f"{1e3 * secs:.1f} ms (IRF cached)")


if __name__ == "__main__":
    main()
