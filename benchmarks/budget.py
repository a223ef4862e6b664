"""Guidance budgets against the wall clock: what a reference second of time_limit_s or replan_budget_s costs here.

    python benchmarks/budget.py [--missions paper,city,helsinki,station] [--replans 10] [--fit] [--json PATH]

A plan's budget is counted in fixed-face QPs at their cost on the reference machine
(:data:`uavsim.guidance.oa.QP_SECONDS` + :data:`uavsim.guidance.oa.QP_SECONDS_PER_NNZ` per
non-zero of the program, less the obstacles the plan cannot touch), so that plans are the
same on any machine; this script measures what that reference second is in wall seconds here.
For every target of each mission it makes the cold first plan (``time_limit_s``) and
``--replans`` rolling re-plans (``replan_budget_s``, each from the previous plan's first
mean plus process noise, as :func:`benchmarks.guidance.rolling` does), and prints per
mission and kind the plans, the reference seconds spent (:attr:`uavsim.guidance.Plan.work_seconds`),
the wall seconds, and their ratio (median, p10, p90, over plans that spent at least 0.05
reference s).  ``--fit`` also prints the constants that make the median ratio 1 (a least-squares fit of wall seconds
per QP against the QP's non-zeros over every plan).

Missions: ``paper`` (missions/paper.toml), ``city`` (a generated city of 50 buildings and 8
targets, seed 11), ``helsinki`` (missions/helsinki.toml) and ``station`` (the 554 x 557 m
crop of central Helsinki round the railway station, imported).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np
from harness import ROOT, markdown_table, parser, run

import uavsim.guidance.oa as oa
from uavsim.cli import main as cli
from uavsim.config import load_mission
from uavsim.guidance import Guidance

STATION_BOX = "24.93736,60.16914,24.94734,60.17414"


def mission_path(name: str, folder: Path) -> Path:
    """The mission file of a named benchmark mission (made in ``folder`` where needed)."""
    if name in ("paper", "helsinki"):
        return ROOT / "missions" / f"{name}.toml"
    out = folder / f"{name}.toml"
    if name == "city":
        cli(["world", "generate", "--kind", "city", "--seed", "11", "--obstacles", "50", "--targets", "8", "--out",
             str(out), "--force"])
    elif name == "station":
        cli(["world", "import", str(ROOT / "worlds" / "osm" / "helsinki-centre.osm.pbf"), "--bbox", STATION_BOX,
             "--out", str(out), "--force"])
    return out


class Counter:
    """Counts the QPs every budget takes and records each budget's reference cost per QP."""

    def __init__(self):
        self.qps, self.cost = 0, 0.0
        self._take = oa.Budget.take

    def __enter__(self):
        counter = self

        def take(budget, need=False):
            ok = counter._take(budget, need)
            if ok:
                counter.qps += 1
                counter.cost = budget.qp_seconds
            return ok

        oa.Budget.take = take
        return self

    def __exit__(self, *exc):
        oa.Budget.take = self._take


def plans(mission, replans: int, rng) -> list[dict]:
    """Every target's first plan and rolling re-plans: kind, wall s, reference s, QPs, cost per QP."""
    g = Guidance(mission.world, mission.dynamics, mission.guidance)
    noise = np.sqrt(np.diag(mission.dynamics.q))
    out = []
    for target in mission.targets:
        goal = mission.world.goals[target.goal].centroid
        mean, prev = target.mean0.copy(), None
        for k in range(replans + 1):
            with Counter() as c:
                t0 = time.perf_counter()
                plan = g.plan(mean, target.cov0, goal, warm=prev, step=k)
                wall = time.perf_counter() - t0
            out.append(dict(kind="first" if prev is None else "re-plan", wall=wall, work=plan.work_seconds, qps=c.qps,
                            qp_cost=c.cost, status=plan.status))
            if not plan.ok:
                break
            prev = plan
            mean = plan.means[0] + rng.standard_normal(6) * noise
            mean[[2, 5]] = 0.0
    return out


def summary(rows: list[dict]) -> dict:
    used = [r for r in rows if r["work"] >= 0.05]
    ratio = np.array([r["wall"] / r["work"] for r in used])
    q = np.quantile(ratio, [0.1, 0.5, 0.9]) if len(ratio) else [np.nan] * 3
    return dict(plans=len(rows), used=len(used), work=sum(r["work"] for r in rows), wall=sum(r["wall"] for r in rows),
                ratio_p10=q[0], ratio_median=q[1], ratio_p90=q[2],
                certified=sum(r["status"] == "optimal" for r in rows) / max(len(rows), 1))


def fit(rows: list[dict]) -> tuple[float, float]:
    """``(a, b)`` with wall seconds per QP ~ a + b nnz (least squares over the plans' QPs,
    each plan weighted by its QPs); nnz from the reference cost the budget charged."""
    rows = [r for r in rows if r["qps"]]
    nnz = np.array([(r["qp_cost"] - oa.QP_SECONDS) / oa.QP_SECONDS_PER_NNZ for r in rows])
    per = np.array([r["wall"] / r["qps"] for r in rows])
    w = np.sqrt([r["qps"] for r in rows])
    (a, b), *_ = np.linalg.lstsq(np.column_stack([w, w * nnz]), w * per, rcond=None)
    return float(a), float(b)


def body(args) -> dict:
    rng = np.random.default_rng(args.seed)
    results, table, every = {}, [], []
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.missions.split(","):
            mission = load_mission(mission_path(name, Path(tmp)))
            rows = plans(mission, args.replans, rng)
            every += rows
            results[name] = {kind: summary([r for r in rows if r["kind"] == kind]) for kind in ("first", "re-plan")}
            for kind, s in results[name].items():
                table.append([name, kind, s["plans"], f"{s['work']:.1f}", f"{s['wall']:.1f}",
                              f"{s['ratio_median']:.3f} ({s['ratio_p10']:.3f}-{s['ratio_p90']:.3f})",
                              f"{100 * s['certified']:.0f}%"])
    print(markdown_table(["mission", "plans", "count", "reference s", "wall s", "wall / reference: median (p10-p90)",
                          "certified"], table))
    out = {"missions": results, "qp_seconds": oa.QP_SECONDS, "qp_seconds_per_nnz": oa.QP_SECONDS_PER_NNZ}
    if args.fit:
        a, b = fit(every)
        print(f"wall seconds per QP ~ {a * 1e3:.3f} ms + {b * 1e6:.4f} us per non-zero "
              f"(now: {oa.QP_SECONDS * 1e3:.3f} ms + {oa.QP_SECONDS_PER_NNZ * 1e6:.4f} us)")
        out["fit"] = {"qp_seconds": a, "qp_seconds_per_nnz": b}
    return out


if __name__ == "__main__":
    ap = parser(__doc__)
    ap.add_argument("--missions", default="paper,city,helsinki,station")
    ap.add_argument("--replans", type=int, default=10)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--fit", action="store_true")
    run(body, ap)
