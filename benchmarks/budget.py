"""Guidance budgets against the wall clock: what a reference second of time_limit_s or replan_budget_s costs here.

    python benchmarks/budget.py [--missions paper,city,helsinki,station,grid] [--replans 10] [--fit] [--json PATH]

A plan's budget is in seconds of the reference machine: each fixed-face QP is charged what
it costs there from what it did (:data:`uavsim.guidance.qp.WORK_CALL_S` per DAQP call,
``WORK_ROW_S`` per row, ``WORK_ITERATION_S`` per iteration, ``WORK_CLARABEL_S`` per Clarabel
solve, and :data:`uavsim.guidance.oa.NODE_SECONDS` for the search round it), so that
plans are the same on any machine; this script measures what that reference second is
in wall seconds here.  For every target of each mission it makes the cold first plan
(``time_limit_s``) and ``--replans`` rolling re-plans (``replan_budget_s``, each from the
previous plan's first mean plus process noise, as :func:`benchmarks.guidance.rolling`
does), and prints per mission and kind the plans, the reference seconds spent
(:attr:`uavsim.guidance.Plan.work_seconds`), the wall seconds, and their ratio (median,
p10, p90, over plans that spent at least 0.05 reference s).  ``--fit`` also prints the
constants a least-squares fit of the plans' wall seconds on their counts (QPs, DAQP calls,
rows, iterations, Clarabel solves) gives.

Missions: ``paper`` (missions/paper.toml), ``city`` (a generated city of 50 buildings and 8
targets, seed 11), ``helsinki`` (missions/helsinki.toml), ``station`` (the 554 x 557 m
crop of central Helsinki round the railway station, imported) and ``grid`` (a street grid
of 42 blocks drawn by hand, benchmarks/towns/grid.toml, whose targets cross the town).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np
from harness import ROOT, markdown_table, parser, run

import uavsim.guidance.oa as oa
import uavsim.guidance.qp as qp
from uavsim.cli import main as cli
from uavsim.config import load_mission
from uavsim.guidance import Guidance

STATION_BOX = "24.93736,60.16914,24.94734,60.17414"


def mission_path(name: str, folder: Path) -> Path:
    """The mission file of a named benchmark mission (made in ``folder`` where needed)."""
    if name in ("paper", "helsinki"):
        return ROOT / "missions" / f"{name}.toml"
    if name == "grid":
        return ROOT / "benchmarks" / "towns" / "grid.toml"
    out = folder / f"{name}.toml"
    if name == "city":
        cli(["world", "generate", "--kind", "city", "--seed", "11", "--obstacles", "50", "--targets", "8", "--out",
             str(out), "--force"])
    elif name == "station":
        cli(["world", "import", str(ROOT / "worlds" / "osm" / "helsinki-centre.osm.pbf"), "--bbox", STATION_BOX,
             "--out", str(out), "--force"])
    return out


class Counter:
    """Counts what the solver does (QPs charged, DAQP calls, rows, iterations, Clarabel
    solves) while it is entered."""

    def __init__(self):
        self.n = dict.fromkeys(("qps", "calls", "rows", "iterations", "clarabel"), 0)
        self._daqp, self._charged, self._solve = qp._daqp, oa.OuterApproximation._charged, qp.ClarabelQP.solve

    def __enter__(self):
        n = self.n

        def daqp(k, a, rows, *args):
            out = self._daqp(k, a, rows, *args)
            n["calls"], n["rows"], n["iterations"] = n["calls"] + 1, n["rows"] + len(rows), n["iterations"] + out[-1]
            return out

        def charged(solver, ctx, y, **kw):
            n["qps"] += 1
            return self._charged(solver, ctx, y, **kw)

        def clarabel(solver, *args, **kw):
            n["clarabel"] += 1
            return self._solve(solver, *args, **kw)

        qp._daqp, oa.OuterApproximation._charged, qp.ClarabelQP.solve = daqp, charged, clarabel
        return self

    def __exit__(self, *exc):
        qp._daqp, oa.OuterApproximation._charged, qp.ClarabelQP.solve = self._daqp, self._charged, self._solve


def plans(mission, replans: int, rng) -> list[dict]:
    """Every target's first plan and rolling re-plans: kind, wall s, reference s, status and the counts."""
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
            out.append(dict(kind="first" if prev is None else "re-plan", wall=wall, work=plan.work_seconds,
                            status=plan.status, **c.n))
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


FIT = ("qps", "calls", "rows", "iterations", "clarabel")


def fit(rows: list[dict]) -> dict[str, float]:
    """Seconds per QP (the search round it), DAQP call, row, iteration and Clarabel solve:
    non-negative least squares of the plans' wall seconds on their counts, each plan
    weighted by 1 / sqrt(its wall time) (relative errors count alike)."""
    from scipy.optimize import nnls

    x = np.array([[r[k] for k in FIT] for r in rows], dtype=float)
    wall = np.array([r["wall"] for r in rows])
    w = 1.0 / np.sqrt(np.maximum(wall, 1e-3))
    coef, _ = nnls(x * w[:, None], wall * w)
    return dict(zip(FIT, coef.tolist()))


def table(results: dict) -> str:
    """The docs table: per mission and kind of plan, reference and wall seconds and their ratio."""
    rows = [[name, kind, s["plans"], f"{s['work']:.1f}", f"{s['wall']:.1f}",
             f"{s['ratio_median']:.2f} ({s['ratio_p10']:.2f}-{s['ratio_p90']:.2f})", f"{100 * s['certified']:.0f}%"]
            for name, kinds in results.items() for kind, s in kinds.items()]
    return markdown_table(["mission", "plans", "count", "reference s", "wall s",
                           "wall / reference, plans of >= 0.05 reference s: median (p10-p90)", "certified"], rows)


def body(args) -> dict:
    rng = np.random.default_rng(args.seed)
    results, every = {}, []
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.missions.split(","):
            mission = load_mission(mission_path(name, Path(tmp)))
            rows = plans(mission, args.replans, rng)
            every += rows
            results[name] = {kind: summary([r for r in rows if r["kind"] == kind]) for kind in ("first", "re-plan")}
    print(table(results))
    now = dict(zip(FIT, (oa.NODE_SECONDS, qp.WORK_CALL_S, qp.WORK_ROW_S, qp.WORK_ITERATION_S, qp.WORK_CLARABEL_S)))
    out = {"missions": results, "work_constants": now}
    if args.fit:
        got = fit(every)
        print("seconds per " + ", ".join(f"{k}: {got[k] * 1e3:.4f} ms (now {now[k] * 1e3:.4f})" for k in FIT))
        out["fit"] = got
    return out


if __name__ == "__main__":
    ap = parser(__doc__)
    ap.add_argument("--missions", default="paper,city,helsinki,station,grid")
    ap.add_argument("--replans", type=int, default=10)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--fit", action="store_true")
    run(body, ap)
