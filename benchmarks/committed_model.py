"""The committed filter's motion model against the planned truth: how far each true path leaves
the affine model of the cluster its start joins.

    python benchmarks/committed_model.py [--worlds osm-medium] [--targets 8] [--clusters 16,64] [--choices 3]
                                         [--trials 20] [--steps 20] [--runs runs/tracking-first-commit]
                                         [--out runs/committed-model] [--json PATH]

With ``motion = "commit"`` a particle whose start lies off its cluster's mean by ``d`` flies
the cluster's plan plus the plan's gains times ``d`` (docs/methods/filter.md): exact while
the plan from its own start keeps the cluster plan's faces and active set.  For each of
``--trials`` trials (the truths of a campaign of that many trials: trial k seeded from
``SeedSequence(seed).spawn(trials)[k]``) and each target, the truth's start joins a cluster
of the first step (:meth:`uavsim.sim.Simulation.first_commit`), and the script flies that
start by the cluster's plan and gains and by every other cluster's, noise-free, for
``--steps`` steps, against the truth's own plan.  Per target-trial: the largest position gap
over the steps with the joined cluster's model (``gap``), with the best of the start's
``--choices`` nearest clusters' (what particles there would fly if each chose among its
nearest clusters: tried and not kept, docs/decisions.md) and with the best cluster's.  With
``--runs``, the campaign folder of ``tracking.py`` (``RUNS/WORLD-nN/optimized``, the same
trials, the mission's own clusters) gives each target-trial's position NEES averaged over
the second half, grouped by its gap (in the row of the mission's ``plan_clusters`` only).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from harness import markdown_table, parser, run
from towns import mission_file

from uavsim.belief.choice import cheapest
from uavsim.belief.particle import join_clusters
from uavsim.campaign import kept_guidance, load_trials, one_blas_thread, trial_seeds
from uavsim.config import load_mission
from uavsim.sim import Simulation, model_positions
from uavsim.targets import HORIZONTAL
from uavsim.world.space import DepthGrid

GAPS = (10.0, 30.0)  # m: the classes a target-trial's gap is counted in


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--worlds", default="osm-medium", help="worlds of towns.py, comma-separated")
    ap.add_argument("--targets", type=int, default=8)
    ap.add_argument("--clusters", default="16", help="plan_clusters values, comma-separated")
    ap.add_argument("--choices", type=int, default=3, help="how many of a start's nearest clusters to try")
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--runs", help="tracking.py's --out of the same trials (optional)")
    ap.add_argument("--out", default="runs/committed-model", help="where the worlds' missions are written")
    run(measure, ap)


def measure(args) -> dict:
    rows = []
    for world in args.worlds.split(","):
        path = mission_file(world, args.targets, Path(args.out))
        late, tracked = second_half_nees(args, path), load_mission(path).filter.plan_clusters
        for k in map(int, args.clusters.split(",")):
            m = load_mission(path, {"trials": args.trials, "steps": args.steps, "filter.plan_clusters": k})
            gap, near, best, cheap = gaps(m, args.choices)
            rows.append(summary(world, k, gap, near, best, cheap, late if k == tracked else None))
            print(markdown_table(head(rows), [cells(rows[-1])]).splitlines()[-1], flush=True)
    print(markdown_table(head(rows), [cells(r) for r in rows]))
    return {"rows": rows}


def gaps(m, choices: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(trials, M)`` each truth's largest gap (m) over the mission's steps to its joined
    cluster's model, to the best of its ``choices`` nearest clusters', to the best cluster's
    and to the cheapest clear cluster's of all (:func:`uavsim.belief.choice.cheapest`: what
    ``route_choice = "cheapest"`` chooses where every cluster holds particles)."""
    guidance, steps = kept_guidance(m), m.steps
    depth = DepthGrid.build(guidance.geom.polys, guidance.geom.area_lo, guidance.geom.area_hi)
    joined, near, best, cheap = (np.zeros((m.trials, len(m.targets))) for _ in range(4))
    with one_blas_thread():
        for i, seed in enumerate(trial_seeds(m.seed, m.trials)):
            sim = Simulation(m, "baseline", guidance)
            sim.reset(seed)
            start = sim.truth.state.copy()  # (M, 6)
            first = sim.first_commit(m.filter.plan_clusters)
            (means, _, scale, live), plans, gains = first.reference, first.plans, first.gains
            models = sim.route_models(first)
            label = join_clusters(start[:, None], means, scale, live)[:, 0]
            dist = (((start[:, None, HORIZONTAL] - means[..., HORIZONTAL]) / scale[:, None]) ** 2).sum(-1)
            order = np.argsort(np.where(live, dist, np.inf), axis=1)[:, :choices]  # (M, choices)
            for j, x0 in enumerate(start):
                truth = sim.truth.plans[j].means[:steps, :2]
                controls = np.array([p.controls[:steps] for p in plans[j]])  # (k, steps, 3)
                flown = model_positions(x0, means[j], controls, gains[j, :, :steps], m.dynamics)
                gap = np.linalg.norm(flown - truth, axis=2).max(axis=1)  # (k,) the start under every cluster
                joined[i, j], near[i, j], best[i, j] = gap[label[j]], gap[order[j]].min(), gap.min()
                every = np.argsort(np.where(live[j], dist[j], np.inf))[None]  # (1, K) nearest first
                cheap[i, j] = gap[cheapest(x0[None], every, means[j], *models[j], depth)[0]]
    return joined, near, best, cheap


def second_half_nees(args, path: Path) -> np.ndarray | None:
    """``(trials, M)`` the position NEES over the second half of the optimized campaign of
    ``--runs`` (None without it)."""
    if not args.runs:
        return None
    results = load_trials(Path(args.runs) / path.stem / "optimized" / "trials", range(args.trials))
    if len(results) < args.trials:
        raise SystemExit(f"{args.runs}: {len(results)} of {args.trials} trials of {path.stem} found")
    return np.stack([results[i].nees_pos[args.steps // 2:].mean(axis=0) for i in range(args.trials)])


def summary(world: str, k: int, gap: np.ndarray, near: np.ndarray, best: np.ndarray, cheap: np.ndarray,
            late: np.ndarray | None) -> dict:
    row = {"world": world, "clusters": k, "target_trials": int(gap.size),
           "gap_percentiles": dict(zip(("50", "75", "90"), np.percentile(gap, [50, 75, 90]).tolist())),
           "over": {f"{g:g}": int((gap > g).sum()) for g in GAPS},
           "near_over": {f"{g:g}": int((near > g).sum()) for g in GAPS},
           "best_over": {f"{g:g}": int((best > g).sum()) for g in GAPS},
           "cheapest_over": {f"{g:g}": int((cheap > g).sum()) for g in GAPS}}
    if late is not None:
        edges = (0.0, *GAPS, np.inf)
        row["nees_by_gap"] = [{"gap_m": [lo, hi], "n": int(s.sum()), "mean": float(late[s].mean()) if s.any() else None,
                               "median": float(np.median(late[s])) if s.any() else None}
                              for lo, hi in zip(edges, edges[1:]) for s in [(gap >= lo) & (gap < hi)]]
        top = np.argsort(late, axis=None)[::-1][:6]
        row["top_tails"] = [{"nees": float(late.flat[i]), "gap_m": float(gap.flat[i])} for i in top]
    return row


HEAD = ["world", "clusters", "target-trials", "gap m: median / 75% / 90%", "gap > 10 m / > 30 m",
        "best of the nearest --choices: gap > 10 m / > 30 m", "best cluster: gap > 10 m / > 30 m",
        "second-half NEES mean by gap < 10 / 10-30 / > 30 m (count)"]


def cells(r: dict) -> list:
    p = r["gap_percentiles"]
    nees = " / ".join(f"{c['mean']:.2f} ({c['n']})" if c["n"] else "- (0)" for c in r.get("nees_by_gap", []))
    return [r["world"], r["clusters"], r["target_trials"], f"{p['50']:.1f} / {p['75']:.1f} / {p['90']:.1f}",
            f"{r['over']['10']} / {r['over']['30']}", f"{r['near_over']['10']} / {r['near_over']['30']}",
            f"{r['best_over']['10']} / {r['best_over']['30']}",
            *([f"{r['cheapest_over']['10']} / {r['cheapest_over']['30']}"] if "cheapest_over" in r else []),
            nees or "-"]


def head(rows: list[dict]) -> list[str]:
    """:data:`HEAD`, with the cheapest clear cluster's column where the rows have it (those
    measured before it was added have not)."""
    return HEAD[:-1] + ["cheapest clear cluster: gap > 10 m / > 30 m"] + HEAD[-1:] if all(
        "cheapest_over" in r for r in rows) else HEAD


if __name__ == "__main__":
    main()
