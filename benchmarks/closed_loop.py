"""Closed-loop speed on the paper mission: seconds per step by stage, trials per minute,
and the Eq. (13) decision alone (61 moves x 4 targets x N particles).

    python benchmarks/closed_loop.py [--mission missions/paper.toml] [--planner optimized] [--trials 3]

Run it with OPENBLAS_NUM_THREADS=1 for the one-core figures a campaign worker sees.
"""

from __future__ import annotations

import time

import numpy as np
from harness import parser, run

from uavsim.campaign import run_trial, trial_seeds
from uavsim.config import load_mission
from uavsim.guidance import Guidance
from uavsim.sim import STAGES, Simulation
from uavsim.uav import candidates, decide


def decision_seconds(mission, repeats=200) -> np.ndarray:
    """Time Eq. (13) on the predicted particles of a real step (step 5 of trial 0)."""
    sim = Simulation(mission, "optimized")
    sim.reset(trial_seeds(mission.seed, 1)[0])
    for _ in range(5):
        sim.step()
    cands, ok = sim.policy.moves()
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        decide(cands, ok, lambda c: sim.belief.traces(c, mission.sensor))
        out.append(time.perf_counter() - t0)
    return np.array(out)


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--mission", default="missions/paper.toml")
    ap.add_argument("--planner", default="optimized")
    ap.add_argument("--trials", type=int, default=3)
    run(measure, ap)


def measure(args) -> None:
    """The benchmark proper, on the parsed arguments (``harness.run`` records what it prints)."""
    mission = load_mission(args.mission, {"trials": args.trials})
    m, n = len(mission.targets), mission.filter.particles

    d = decision_seconds(mission)
    print(f"Eq. (13) decision, {len(candidates(mission.uav.start, mission.uav))} moves x {m} targets x {n} particles: "
          f"median {1e3 * np.median(d):.2f} ms, p90 {1e3 * np.quantile(d, 0.9):.2f} ms")

    t0 = time.perf_counter()
    guidance = Guidance(mission.world, mission.dynamics, mission.guidance)
    secs, walls = [], []
    for k, seed in enumerate(trial_seeds(mission.seed, args.trials)):
        t1 = time.perf_counter()
        secs.append(run_trial(mission, args.planner, k, seed, guidance).seconds)
        walls.append(time.perf_counter() - t1)
    total = time.perf_counter() - t0
    secs = np.concatenate(secs)
    print(f"\n{args.planner} on {mission.path}: {args.trials} trials x {mission.steps} steps, {n} particles")
    print(f"{'stage':<10}{'median s/step':>15}{'p90':>10}{'max':>10}")
    for i, stage in enumerate(STAGES):
        col = secs[:, i]
        print(f"{stage:<10}{np.median(col):>15.4f}{np.quantile(col, 0.9):>10.4f}{col.max():>10.4f}")
    print(f"trials per minute: {60 * args.trials / total:.2f} (first trial {walls[0]:.1f} s incl. building the "
          f"guidance models, later trials median {np.median(walls[1:] or walls):.1f} s)")


if __name__ == "__main__":
    main()
