"""Guidance (P1) speed on the paper mission: cold solves, a rolling horizon, SCIP; before/after DAQP (commit d6ed022).

For every target: one cold solve from the prior mean; then a rolling horizon of
``--steps`` re-plans, each from the previous plan's first predicted mean plus process
noise N(0, Q) (what a closed loop feeds the guidance), warm-started from the previous
plan.  Prints median and max re-plan seconds, master MILPs per re-plan, the largest
certified gap, and the statuses.  With pyscipopt installed, SCIP (through cvxpy, no gap
limit) cold-solves the same problems for the speed ratio (``--no-scip`` skips it).

``--before`` also runs everything with the fixed-face QP solved by Clarabel, the method
before DAQP (commit d6ed022; a new solver object per QP, :class:`uavsim.guidance.qp.ClarabelQP`), same seed and
budgets, and prints before/after: the QPs alone (CPU seconds per
QP as solved inside the plans), the cold plans and the re-plans (wall and CPU seconds),
the largest relative difference of the objectives, how the QPs were settled
(:attr:`uavsim.guidance.qp.FixedFaceQP.counts`), and the seconds per closed-loop step
by stage (``--trials`` trials of the optimized policy, mean, median and p90).

    python benchmarks/guidance.py [--mission missions/paper.toml] [--steps 50] [--seed 1] [--before] [--trials 2]
        [--no-scip] [--reference-plans]
"""

from __future__ import annotations

import importlib.util
import time
from collections import Counter
from dataclasses import replace

import harness
import numpy as np

from uavsim.campaign import run_trial, trial_seeds
from uavsim.config import load_mission
from uavsim.guidance import Guidance
from uavsim.guidance.oa import OuterApproximation
from uavsim.sim import STAGES


def rolling(guidance, mission, target, steps, rng):
    """Re-plan ``steps`` times along the plan; returns per re-plan (seconds, masters, gap, status)."""
    return [o[:4] for o in rolling_plans(guidance, mission, target, steps, rng)]


def rolling_plans(guidance, mission, target, steps, rng):
    """As :func:`rolling`, each entry also with the CPU seconds and the objective."""
    goal = mission.world.goals[target.goal].centroid
    noise = np.sqrt(np.diag(mission.dynamics.q))
    mean, cov, prev, out = target.mean0.copy(), target.cov0, None, []
    for _ in range(steps):
        c0 = time.process_time()
        plan = guidance.plan(mean, cov, goal, warm=prev)
        out.append((plan.solve_seconds, plan.iterations, plan.gap, plan.status, time.process_time() - c0,
                    plan.objective))
        if not plan.ok:  # what the closed loop does: keep flying the previous plan
            plan = prev.shifted(mission.dynamics, mean, cov, plan.message)
        prev = plan
        mean = plan.means[0] + rng.standard_normal(6) * noise
        mean[[2, 5]] = 0.0  # ground targets
    return out


class QpTimer:
    """Times the fixed-face QP of every horizon's program (``clarabel``: Clarabel only, the
    method before DAQP, commit d6ed022) and keeps the CPU seconds of each QP solved and the QPs'
    :attr:`~uavsim.guidance.qp.FixedFaceQP.counts`."""

    def __init__(self, guidance: Guidance, clarabel: bool):
        self.seconds, self.qps = [], []
        inner = guidance._model

        def model(horizon):
            reach, oa = inner(horizon)
            if not getattr(oa.qp, "_timed", False):
                qp = oa.qp
                if clarabel:
                    qp.condensed = None  # every QP by Clarabel, every plan Clarabel's
                self.qps.append(qp)
                solve = qp.solve

                def timed(*args, **kwargs):
                    t0 = time.process_time()
                    try:
                        return solve(*args, **kwargs)
                    finally:
                        self.seconds.append(time.process_time() - t0)

                qp.solve, qp._timed = timed, True
            return reach, oa

        guidance._model = model

    @property
    def counts(self) -> dict:
        return {k: sum(q.counts[k] for q in self.qps) for k in self.qps[0].counts} if self.qps else {}


def run(mission, steps, seed, before: bool) -> dict:
    """Cold plans and rolling re-plans of every target, with one QP method."""
    g = Guidance(mission.world, mission.dynamics, mission.guidance)
    timer = QpTimer(g, clarabel=before)
    cold = []
    for t in mission.targets:
        c0 = time.process_time()
        plan = g.plan(t.mean0, t.cov0, mission.world.goals[t.goal].centroid)
        cold.append((plan.solve_seconds, time.process_time() - c0, plan.objective, plan.status))
    n_cold = len(timer.seconds)
    rng = np.random.default_rng(seed)
    warm = [rolling_plans(g, mission, t, steps + 1, rng)[1:] for t in mission.targets]
    return {"cold": cold, "warm": warm, "qp_cold": timer.seconds[:n_cold], "qp_all": timer.seconds,
            "counts": timer.counts}


def closed_loop(mission, trials, before: bool) -> tuple[np.ndarray, float]:
    """Wall seconds per step by stage (:data:`uavsim.sim.STAGES`) of ``trials``
    closed-loop trials of the optimized policy, one QP method; and the CPU seconds per
    step (whole trials, resets included: what a loaded machine does not inflate)."""
    g = Guidance(mission.world, mission.dynamics, mission.guidance)
    QpTimer(g, clarabel=before)
    c0 = time.process_time()
    secs = np.concatenate([run_trial(mission, "optimized", k, seed, g).seconds
                           for k, seed in enumerate(trial_seeds(mission.seed, trials))])
    return secs, (time.process_time() - c0) / len(secs)


def q3(x) -> str:
    x = np.asarray(x, float)
    return f"{np.median(x) * 1e3:7.2f} {np.quantile(x, 0.9) * 1e3:7.2f} {x.max() * 1e3:7.2f}"


def rel(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    both = np.isfinite(a) & np.isfinite(b)
    if np.any(np.isfinite(a) != np.isfinite(b)):
        return np.inf
    return float(np.max(np.abs(a[both] - b[both]) / np.maximum(np.abs(b[both]), 1.0), initial=0.0))


def before_after(mission, steps, seed, trials) -> dict:
    """Print before/after figures (module docstring) and return them (ms)."""
    runs = {"before": run(mission, steps, seed, before=True), "after": run(mission, steps, seed, before=False)}
    plans = "DAQP's optima" if not OuterApproximation.reference_plans else "Clarabel's re-solve of the chosen QP"
    print(f"\nbefore (Clarabel) / after (DAQP) (ms: median p90 max; CPU = process time, wall = perf_counter); "
          f"the same budgets; plans returned after: {plans}")
    print(f"{'':<26}{'before':>24}{'after':>24}{'median speed-up':>17}")
    for label, key in (("QP alone, CPU", "qp_all"),):
        b, a = runs["before"][key], runs["after"][key]
        print(f"{label:<26}{q3(b):>24}{q3(a):>24}{np.median(b) / np.median(a):>16.1f}x")
    for i, t in enumerate(mission.targets):
        b = [o[0] for o in runs["before"]["warm"][i]]
        a = [o[0] for o in runs["after"]["warm"][i]]
        bc = [o[4] for o in runs["before"]["warm"][i]]
        ac = [o[4] for o in runs["after"]["warm"][i]]
        print(f"{'re-plans ' + t.name + ', wall':<26}{q3(b):>24}{q3(a):>24}{np.median(b) / np.median(a):>16.1f}x")
        print(f"{'re-plans ' + t.name + ', CPU':<26}{q3(bc):>24}{q3(ac):>24}{np.median(bc) / np.median(ac):>16.1f}x")
    b = [o[0] for w in runs["before"]["warm"] for o in w]
    a = [o[0] for w in runs["after"]["warm"] for o in w]
    print(f"{'re-plans all, wall':<26}{q3(b):>24}{q3(a):>24}{np.median(b) / np.median(a):>16.1f}x")
    bc = [o[4] for w in runs["before"]["warm"] for o in w]
    ac = [o[4] for w in runs["after"]["warm"] for o in w]
    print(f"{'re-plans all, CPU':<26}{q3(bc):>24}{q3(ac):>24}{np.median(bc) / np.median(ac):>16.1f}x")
    for i, t in enumerate(mission.targets):
        b, a = runs["before"]["cold"][i], runs["after"]["cold"][i]
        print(f"{'cold ' + t.name + ', wall / CPU':<26}{b[0] * 1e3:>11.1f} /{b[1] * 1e3:>9.1f}"
              f"{a[0] * 1e3:>13.1f} /{a[1] * 1e3:>9.1f}{b[0] / a[0]:>16.1f}x")
    cold = rel([o[2] for o in runs["after"]["cold"]], [o[2] for o in runs["before"]["cold"]])
    warm = rel([o[5] for w in runs["after"]["warm"] for o in w], [o[5] for w in runs["before"]["warm"] for o in w])
    statuses = {k: dict(Counter(o[3] for w in r["warm"] for o in w)) for k, r in runs.items()}
    print(f"largest relative objective difference after vs before: cold plans {cold:.1e}, re-plans {warm:.1e}")
    print(f"re-plan statuses: {statuses}")
    print(f"how the QPs were settled: {runs['after']['counts']}")
    figures = {"qp_cpu_ms": {k: 1e3 * float(np.median(r["qp_all"])) for k, r in runs.items()},
               "replan_cpu_ms": {k: 1e3 * float(np.median([o[4] for w in r["warm"] for o in w]))
                                 for k, r in runs.items()},
               "cold_cpu_ms": {k: [1e3 * o[1] for o in r["cold"]] for k, r in runs.items()},
               "objective_rel_diff": {"cold": cold, "replans": warm}, "statuses": statuses,
               "qp_counts": runs["after"]["counts"], "replans": sum(len(w) for w in runs["after"]["warm"])}
    if trials <= 0:
        return figures
    loops = {k: closed_loop(mission, trials, k == "before") for k in ("before", "after")}
    print(f"\nclosed loop, optimized policy, {len(mission.targets)} targets, {trials} trials x {mission.steps} steps "
          "(ms per step: mean median p90)")
    print(f"{'':<26}{'before':>24}{'after':>24}{'mean speed-up':>17}")
    for i, stage in enumerate(STAGES):
        b, a = loops["before"][0][:, i], loops["after"][0][:, i]
        print(f"{stage:<26}{np.mean(b) * 1e3:>8.1f}{np.median(b) * 1e3:>8.1f}{np.quantile(b, 0.9) * 1e3:>8.1f}"
              f"{np.mean(a) * 1e3:>16.1f}{np.median(a) * 1e3:>8.1f}{np.quantile(a, 0.9) * 1e3:>8.1f}"
              f"{np.mean(b) / np.mean(a):>16.1f}x")
    b, a = loops["before"][1], loops["after"][1]
    print(f"{'total, CPU (mean)':<26}{b * 1e3:>8.1f}{a * 1e3:>40.1f}{b / a:>16.1f}x")
    total = STAGES.index("total")
    figures["step_wall_ms"] = {k: 1e3 * float(np.mean(v[0][:, total])) for k, v in loops.items()}
    figures["step_cpu_ms"] = {k: 1e3 * v[1] for k, v in loops.items()}
    figures["trials"] = trials
    return figures


def main() -> None:
    ap = harness.parser(__doc__)
    ap.add_argument("--mission", default="missions/paper.toml")
    ap.add_argument("--steps", type=int, default=50)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--scip-time-limit", type=float, default=120.0)
    ap.add_argument("--no-scip", action="store_true", help="skip the SCIP comparison")
    ap.add_argument("--before", action="store_true", help="also print before (Clarabel) / after (DAQP)")
    ap.add_argument("--trials", type=int, default=2, help="closed-loop trials per method for --before's step times")
    ap.add_argument("--reference-plans", action="store_true",
                    help="plans re-solved by Clarabel (OuterApproximation.reference_plans)")
    harness.run(measure, ap)


def measure(args) -> dict:
    """The benchmark proper, on the parsed arguments (``harness.run`` records what it prints
    and the figures returned)."""
    OuterApproximation.reference_plans = args.reference_plans
    mission = load_mission(args.mission)
    t0 = time.perf_counter()
    guidance = Guidance(mission.world, mission.dynamics, mission.guidance)
    print(f"build + compile: {time.perf_counter() - t0:.3f} s; horizon T = {mission.guidance.horizon}, "
          f"gap tolerance {mission.guidance.gap:g}")

    has_scip = importlib.util.find_spec("pyscipopt") is not None and not args.no_scip
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
        print("(SCIP columns skipped: --no-scip, or pip install pyscipopt)")

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
    figures = {"replan_wall_ms": {"median": 1e3 * float(np.median(every)), "p90": 1e3 * float(np.quantile(every, 0.9)),
                                  "max": 1e3 * float(every.max())}}
    if args.before:
        figures["before_after"] = before_after(mission, args.steps, args.seed, args.trials)
    return figures


if __name__ == "__main__":
    main()
