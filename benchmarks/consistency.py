"""Why the towns' beliefs are wider than their errors: the filter's forces against the truth's.

    python benchmarks/consistency.py [--worlds osm-small] [--trials 10] [--steps 20] [--force-trials 5]
                                     [--link] [--workers 2] [--out runs/consistency] [--json PATH]

Each world's mission as ``benchmarks/towns.py`` makes it (8 targets; an imported town has line
of sight on), flown by the optimized UAV.

* **Forces.** For ``--force-trials`` trials, at every step and for every target: the force
  the true target applies (its noise-free plan's, made once from its start: the paper's
  truth), the force of a re-plan from the true state itself (what the filter would apply to
  a particle exactly on the truth; cold-started, and the share of them certified optimal),
  and the first force of the filter's plan for the half of its cloud whose mean is nearest
  the truth.  Quantiles of the differences, in newtons.
* **Given the truth's forces.** The same trials with the filter predicting by the true
  targets' own forces (``Simulation(..., oracle=True)``), once with the mission's noise
  levels and once with levels 30 times smaller, beside the filter as it is: the position
  NEES (mean, median against chi-square(2)'s 1.39, share of steps in its band) and what a
  calibrated filter with the same beliefs would have in band
  (:func:`uavsim.metrics.consistency`).

``--link``: every mission with P1's link term (``[guidance] link_applied_force``; the truth's
plans too), the re-plan from the true state linked to the truth's own last force (a planned
truth's, as ``towns.py`` makes them; a stochastic truth's last plan is gone by then, and its
re-plan links to zero).
``--trials 0`` measures the forces only.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from harness import markdown_table, parser, run, run_cells
from towns import mission_file

from uavsim import metrics
from uavsim.campaign import kept_guidance, one_blas_thread, run_trial, trial_seeds
from uavsim.config import load_mission
from uavsim.sim import Simulation

QUIET = 30.0  # the quieter levels: the mission's divided by this
VARIANTS = ("filter", "truth's forces", "truth's forces, levels / 30")


def forces(world: str, k: int, steps: int, paths: dict, extra: dict) -> np.ndarray:
    """``(steps x M, 4)`` per target-step: |truth - re-plan from the truth|, |truth - nearest
    half's plan|, |truth| (N), and 1 where the re-plan from the truth was certified optimal;
    ``extra``: mission overrides."""
    m = load_mission(paths[world], {"steps": steps, **extra})
    rows = []
    with one_blas_thread():
        sim = Simulation(m, "optimized", kept_guidance(m))
        sim.reset(trial_seeds(m.seed, k + 1)[k])
        zero = np.zeros((6, 6))
        for t in range(steps):
            sim.prepare()
            _, _, means, _ = sim.belief.halves()
            for j, x in enumerate(sim.truth.state):
                plan = sim.truth.plans[j]  # planned: made once (and past each horizon); stochastic: this step's
                k_t = t % len(plan.controls) if m.truth == "planned" else 0
                u = plan.controls[k_t, :2]
                applied = plan.controls[k_t - 1] if m.truth == "planned" and k_t else None  # the link term's
                again = sim.guidance.replan(x, zero, m.goals[j], None, t, 1, applied)
                halves = sim.half_plans[j] or [sim.plans[j]]
                near = int(np.argmin(np.hypot(*(means[j, :len(halves), :2] - x[:2]).T)))
                rows.append([np.hypot(*(u - again.controls[0, :2])), np.hypot(*(u - halves[near].controls[0, :2])),
                             np.hypot(*u), again.status == "optimal"])
            sim.step()
    return np.array(rows)


def trial(world: str, variant: str, k: int, trials: int, steps: int, paths: dict, extra: dict) -> dict:
    over = {"steps": steps, "trials": trials, **extra}
    if variant.endswith("/ 30"):
        over["filter.noise_scales"] = [s / QUIET for s in load_mission(paths[world]).filter.noise_scales]
    m = load_mission(paths[world], over)
    r = run_trial(m, "optimized", k, trial_seeds(m.seed, trials)[k], kept_guidance(m),
                  oracle=variant != "filter")
    return {"nees": r.nees_pos, "ref": r.nees_ref, "err2": r.err2}


def summary(results: list[dict]) -> dict:
    nees = np.stack([r["nees"] for r in results])
    c = metrics.consistency(nees, 2, reference=np.stack([r["ref"] for r in results]))
    return {"nees_mean": float(nees.mean()), "nees_median": float(np.median(nees)), "inside": c["inside"],
            "below": c["below"], "above": c["above"], "calibrated_inside": c["calibrated"]["inside"],
            "rmse": float(np.sqrt(np.stack([r["err2"] for r in results]).mean()))}


def main(args) -> dict:
    out = Path(args.out)
    worlds = args.worlds.split(",")
    paths = {w: mission_file(w, 8, out / w) for w in worlds}  # written once, before the workers read them
    extra = {"guidance.link_applied_force": True} if args.link else {}
    cells = [(w, k) for w in worlds for k in range(args.force_trials)]
    done = run_cells(forces, cells, (args.steps, paths, extra), args.workers, "forces")
    rows = []
    for w in worlds:
        f = np.concatenate([done[(w, k)] for k in range(args.force_trials) if (w, k) in done])
        q = [50, 75, 90, 99]
        rows.append({"world": w, "target_steps": len(f), "replan_quantiles": np.percentile(f[:, 0], q).tolist(),
                     "replan_above_100": float(np.mean(f[:, 0] > 100)), "replan_optimal": float(np.mean(f[:, 3])),
                     "half_quantiles": np.percentile(f[:, 1], q).tolist(),
                     "half_above_100": float(np.mean(f[:, 1] > 100)), "force_median": float(np.median(f[:, 2]))})
    cells = [(w, v, k) for w in worlds for v in VARIANTS for k in range(args.trials)]
    done = run_cells(trial, cells, (args.trials, args.steps, paths, extra), args.workers, "trial")
    oracle = [{"world": w, "variant": v, "trials": args.trials,
               **summary([done[(w, v, k)] for k in range(args.trials) if (w, v, k) in done])}
              for w in worlds for v in VARIANTS] if args.trials else []
    print(force_table(rows))
    if oracle:
        print()
        print(oracle_table(oracle))
    return {"forces": rows, "oracle": oracle, "link": args.link}


def force_table(rows: list[dict]) -> str:
    head = ["world", "target-steps", "truth's force, median",
            "truth's force less a re-plan's from the true state: p50 / p75 / p90 / p99", "above 100 N",
            "those re-plans certified optimal",
            "less the filter's nearest half's: p50 / p75 / p90 / p99", "above 100 N"]
    body = [[r["world"], r["target_steps"], f"{r['force_median']:.0f} N",
             " / ".join(f"{v:.0f}" for v in r["replan_quantiles"]) + " N", f"{100 * r['replan_above_100']:.0f}%",
             f"{100 * r['replan_optimal']:.0f}%" if "replan_optimal" in r else "-",  # JSON written before it was kept
             " / ".join(f"{v:.0f}" for v in r["half_quantiles"]) + " N", f"{100 * r['half_above_100']:.0f}%"]
            for r in rows]
    return markdown_table(head, body)


def oracle_table(rows: list[dict]) -> str:
    head = ["world", "filter predicts with", "RMSE m", "NEES pos mean", "median (chi-square 1.39)",
            "in band / below / above", "a calibrated filter in band"]
    body = [[r["world"], r["variant"], f"{r['rmse']:.1f}", f"{r['nees_mean']:.2f}", f"{r['nees_median']:.2f}",
             f"{100 * r['inside']:.0f} / {100 * r['below']:.0f} / {100 * r['above']:.0f}%",
             f"{100 * r['calibrated_inside']:.0f}%"] for r in rows]
    return markdown_table(head, body)


if __name__ == "__main__":
    ap = parser(__doc__)
    ap.add_argument("--worlds", default="osm-small")
    ap.add_argument("--trials", type=int, default=10)
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--force-trials", type=int, default=5)
    ap.add_argument("--link", action="store_true", help="P1 with the link term (guidance.link_applied_force)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default="runs/consistency")
    run(main, ap)
