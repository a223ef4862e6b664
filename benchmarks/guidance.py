"""Guidance (P1) speed on the paper mission: cold solves, a rolling horizon, SCIP.

For every target: one cold solve from the prior mean; then a rolling horizon of
``--steps`` re-plans, each from the previous plan's first predicted mean plus process
noise N(0, Q) (what a closed loop feeds the guidance), warm-started from the previous
plan.  Prints median and max re-plan seconds, master MILPs per re-plan, the largest
certified gap, and the statuses.  With pyscipopt installed, SCIP (through cvxpy, no gap
limit) cold-solves the same problems for the speed ratio.

    python benchmarks/guidance.py [--mission missions/paper.toml] [--steps 50] [--seed 1]
"""

from __future__ import annotations

import argparse
import importlib.util
import time
from collections import Counter
from dataclasses import replace

import numpy as np

from uavsim.config import load_mission
from uavsim.guidance import Guidance


def rolling(guidance, mission, target, steps, rng):
    """Re-plan ``steps`` times along the plan; returns per re-plan (seconds, masters, gap, status)."""
    goal = mission.world.goals[target.goal].centroid
    noise = np.sqrt(np.diag(mission.dynamics.q))
    mean, cov, prev, out = target.mean0.copy(), target.cov0, None, []
    for _ in range(steps):
        plan = guidance.plan(mean, cov, goal, warm=prev)
        out.append((plan.solve_seconds, plan.iterations, plan.gap, plan.status))
        if not plan.ok:  # what the closed loop does: keep flying the previous plan
            plan = prev.shifted(mission.dynamics, mean, cov, plan.message)
        prev = plan
        mean = plan.means[0] + rng.standard_normal(6) * noise
        mean[[2, 5]] = 0.0  # ground targets
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mission", default="missions/paper.toml")
    ap.add_argument("--steps", type=int, default=50)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--scip-time-limit", type=float, default=120.0)
    args = ap.parse_args()
    mission = load_mission(args.mission)
    t0 = time.perf_counter()
    guidance = Guidance(mission.world, mission.dynamics, mission.guidance)
    print(f"build + compile: {time.perf_counter() - t0:.3f} s; horizon T = {mission.guidance.horizon}, "
          f"gap tolerance {mission.guidance.gap:g}")

    has_scip = importlib.util.find_spec("pyscipopt") is not None
    scip = Guidance(mission.world, mission.dynamics, replace(mission.guidance, time_limit=args.scip_time_limit),
                    solver="scip") if has_scip else None
    print("\ncold solves from the prior mean")
    print(f"{'target':<8}{'HiGHS-OA s':>11}{'objective':>14}{'gap':>9}{'masters':>8}"
          f"{'SCIP s':>9}{'SCIP objective':>16}{'SCIP status':>13}{'speed-up':>9}")
    for t in mission.targets:
        goal = mission.world.goals[t.goal].centroid
        a = guidance.plan(t.mean0, t.cov0, goal)
        line = f"{t.name:<8}{a.solve_seconds:>11.3f}{a.objective:>14.4f}{a.gap:>9.1e}{a.iterations:>8}"
        if scip is not None:
            b = scip.plan(t.mean0, t.cov0, goal)
            ratio = b.solve_seconds / a.solve_seconds
            line += f"{b.solve_seconds:>9.2f}{b.objective:>16.4f}{b.status:>13}{ratio:>8.0f}x"
        print(line)
    if scip is None:
        print("(SCIP columns skipped: pip install pyscipopt)")

    print(f"\nrolling horizon: {args.steps} warm re-plans per target, seed {args.seed}")
    print(f"{'target':<8}{'median s':>9}{'p90 s':>8}{'max s':>8}{'masters/re-plan 0,1,2,3+':>26}"
          f"{'max gap':>9}  statuses")
    rng = np.random.default_rng(args.seed)
    every = []
    for t in mission.targets:
        out = rolling(guidance, mission, t, args.steps + 1, rng)[1:]  # the first solve is cold
        secs = np.array([o[0] for o in out])
        every += list(secs)
        masters = np.bincount(np.minimum([o[1] for o in out], 3), minlength=4)
        gaps = [o[2] for o in out if np.isfinite(o[2])]
        statuses = dict(Counter(o[3] for o in out))
        print(f"{t.name:<8}{np.median(secs):>9.3f}{np.quantile(secs, 0.9):>8.3f}{secs.max():>8.3f}"
              f"{str(masters.tolist()):>26}{max(gaps):>9.1e}  {statuses}")
    every = np.array(every)
    print(f"{'all':<8}{np.median(every):>9.3f}{np.quantile(every, 0.9):>8.3f}{every.max():>8.3f}")


if __name__ == "__main__":
    main()
