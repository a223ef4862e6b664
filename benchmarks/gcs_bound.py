"""Does a graph-of-convex-sets relaxation bound P1 more tightly than branching?

    python benchmarks/gcs_bound.py [--cities 11:50:8,13:100:16] [--targets 4] [--out runs/gcs]
    python benchmarks/gcs_bound.py --report runs/gcs/gcs.json      # the docs' markdown table

[Marcucci2023] plans around obstacles by a shortest path in a graph whose vertices are
convex free regions, with every edge's constraints and cost written in perspective; the
convex relaxation of that mixed-integer program is often tight.  Here P1 is written that
way on a time-expanded graph:

* free space (area minus the inflated footprints) is covered by maximal free rectangles
  (grown from the cells of a compressed grid of the rectangles' edges); vertex (tau, k) says ``p_tau``
  lies in rectangle k, for tau = 2..T and the rectangles the reachable set of plans with
  ``f <= UB`` meets at tau (:meth:`uavsim.guidance.faces.Reach.face_bounds`, UB the
  solver's optimum);
* an edge joins (tau, k) to (tau + 1, k') when the rectangles are within ``v_max dt``; it
  carries ``phi`` (its flow), ``phi (p_tau, v_tau, u_{tau-1})``, ``phi u_tau`` and the
  cost ``rho |u_tau - u_{tau-1}|^2 / phi`` (a rotated cone); the dynamics Eq. (8b), the
  force and speed limits and both ends' rectangles hold on it in perspective;
* flow and state are conserved at every vertex; one unit leaves the start (``p_1`` fixed,
  ``u_0`` free); the terminal cost ``|p_T - G|^2`` is taken in perspective per final vertex.

With binary flows this is P1 (every collision-free plan picks a rectangle per step), so
the relaxation bounds P1 from below.  Printed and written (``OUT/gcs.json``) per target:
the certified optimum, the obstacle-free QP (the root bound of the branch-and-bound), the
GCS bound, their ratios to the optimum, and the seconds.
"""

from __future__ import annotations

import argparse
import json
import time
from collections import defaultdict
from dataclasses import replace
from pathlib import Path

import clarabel
import numpy as np
import scipy.sparse as sp
from harness import machine, markdown_table, write

from uavsim.config import load_mission
from uavsim.guidance import Guidance
from uavsim.guidance.model import KN
from uavsim.world.generate import generate, mission_toml, world_toml

PHI, WP, WV, WU, MU, TT, WIDTH = 0, 1, 3, 5, 7, 9, 10  # an edge's columns: phi, w = phi (p, v, u_prev), phi u, t


def rectangles(lo, hi, area_lo, area_hi) -> np.ndarray:
    """``(K, 2, 2)`` maximal free rectangles covering the free space outside the
    rectangles ``[lo, hi]``, grown from the largest uncovered free cell of the compressed
    grid (the rectangles' and the area's edges cut the area into cells, each wholly free
    or wholly covered) until no side can move."""
    a_lo, a_hi = np.asarray(area_lo)[:2], np.asarray(area_hi)[:2]
    xs = np.unique(np.r_[np.clip(lo[:, 0], a_lo[0], a_hi[0]), np.clip(hi[:, 0], a_lo[0], a_hi[0]), a_lo[0], a_hi[0]])
    ys = np.unique(np.r_[np.clip(lo[:, 1], a_lo[1], a_hi[1]), np.clip(hi[:, 1], a_lo[1], a_hi[1]), a_lo[1], a_hi[1]])
    cx, cy = 0.5 * (xs[1:] + xs[:-1]), 0.5 * (ys[1:] + ys[:-1])
    free = ~(((cx[:, None] > lo[:, 0]) & (cx[:, None] < hi[:, 0]))[:, None, :]
             & ((cy[:, None] > lo[:, 1]) & (cy[:, None] < hi[:, 1]))[None, :, :]).any(axis=-1)
    nx, ny = free.shape
    covered = np.zeros_like(free)
    out = []
    for flat in np.argsort(-(np.diff(xs)[:, None] * np.diff(ys)[None, :]).ravel(), kind="stable"):
        i, j = divmod(int(flat), ny)
        if not free[i, j] or covered[i, j]:
            continue
        i0, i1, j0, j1 = i, i + 1, j, j + 1
        grown = True
        while grown:
            grown = False
            for di0, di1, dj0, dj1 in ((0, 1, 0, 0), (-1, 0, 0, 0), (0, 0, 0, 1), (0, 0, -1, 0)):
                a0, a1, b0, b1 = i0 + di0, i1 + di1, j0 + dj0, j1 + dj1
                if 0 <= a0 and a1 <= nx and 0 <= b0 and b1 <= ny and free[a0:a1, b0:b1].all():
                    i0, i1, j0, j1, grown = a0, a1, b0, b1, True
        covered[i0:i1, j0:j1] = True
        out.append(((xs[i0], ys[j0]), (xs[i1], ys[j1])))
    return np.array(out)


class Program:
    """Rows of a conic program ``A z + s = b``: equalities, inequalities, second-order cones."""

    def __init__(self):
        self.eq, self.le, self.cones = [], [], []

    @staticmethod
    def row(terms) -> tuple[list, list]:
        cols, vals = [], []
        for c, v in terms:
            cols.append(c)
            vals.append(v)
        return cols, vals

    def add_eq(self, terms, rhs=0.0):
        self.eq.append((*self.row(terms), rhs))

    def add_le(self, terms, rhs=0.0):
        self.le.append((*self.row(terms), rhs))

    def add_cone(self, rows):  # rows[0] >= || rows[1:] ||, each row a list of (col, coefficient)
        self.cones.append([self.row(r) for r in rows])

    def solve(self, n: int, cost: np.ndarray) -> tuple[float, str]:
        def mat(rows):
            r = np.repeat(np.arange(len(rows)), [len(c) for c, *_ in rows])
            c = np.concatenate([c for c, *_ in rows]) if rows else np.zeros(0, int)
            v = np.concatenate([v for _, v, *_ in rows]) if rows else np.zeros(0)
            return sp.csc_matrix((v, (r, c)), shape=(len(rows), n))

        cone_rows = [r for cone in self.cones for r in cone]
        a = sp.vstack([mat(self.eq), mat(self.le), -mat([(c, v) for c, v in cone_rows])]).tocsc()
        b = np.r_[[r[2] for r in self.eq], [r[2] for r in self.le], np.zeros(len(cone_rows))]
        cones = [clarabel.ZeroConeT(len(self.eq)), clarabel.NonnegativeConeT(len(self.le))]
        cones += [clarabel.SecondOrderConeT(len(cone)) for cone in self.cones]
        settings = clarabel.DefaultSettings()
        settings.verbose = False
        sol = clarabel.DefaultSolver(sp.csc_matrix((n, n)), cost, a, b, cones, settings).solve()
        return float(sol.obj_val), str(sol.status)


def gcs_bound(g: Guidance, x0: np.ndarray, goal: np.ndarray, ub: float, rects: np.ndarray) -> dict:
    """The relaxation's value for the start ``x0 = [p, v]`` and ``goal (2,)``: see module docstring."""
    dyn, cfg, geom = g.dynamics, g.cfg, g.geom
    horizon, dt, keep = cfg.horizon, dyn.dt, 1.0 - dyn.friction
    gain, f_max, rho = dt * KN / dyn.mass, cfg.force_max / KN, cfg.rho * KN**2
    lo, hi = g.oa.c.rows(np.r_[x0, goal])
    relax = g.oa.qp.solve(lo, hi, np.ones(g.oa.shape), relax=True)
    box_lo, box_hi = g.reach.face_bounds(x0, goal, geom.face_normals, ub, (relax.x[2:, :2], relax.f)).boxes
    verts = [np.flatnonzero(np.all((rects[:, 1] >= box_lo[r]) & (rects[:, 0] <= box_hi[r]), axis=1))
             for r in range(horizon - 1)]
    edges = [(-1, -1, 0, int(k)) for k in verts[0]]  # (tail step row, tail rect, head step row, head rect)
    for r in range(horizon - 2):
        a, b = rects[verts[r]], rects[verts[r + 1]]
        gap = np.maximum(0, np.maximum(a[:, None, 0] - b[None, :, 1], b[None, :, 0] - a[:, None, 1]))
        ii, jj = np.nonzero(np.linalg.norm(gap, axis=-1) <= cfg.speed_max * dt + 1e-9)
        edges += [(r, int(verts[r][i]), r + 1, int(verts[r + 1][j])) for i, j in zip(ii, jj)]
    n_e = len(edges)
    u0, q0 = n_e * WIDTH, n_e * WIDTH + 2
    last = verts[-1]
    n = q0 + len(last)
    prog = Program()

    def col(e, k):
        return e * WIDTH + k

    def head(e, part, i):  # the head state of edge e, in perspective: Eq. (8b)
        if part == "p":
            return [(col(e, WP + i), 1.0), (col(e, WV + i), dt)]
        if part == "v":
            return [(col(e, WV + i), keep), (col(e, MU + i), gain)]
        return [(col(e, MU + i), 1.0)]

    sources = [e for e, edge in enumerate(edges) if edge[0] == -1]
    p1, v0 = x0[:2] + dt * x0[2:], x0[2:]
    prog.add_eq([(col(e, PHI), 1.0) for e in sources], 1.0)
    for i in range(2):  # the start state (p_1, v_1, u_0) with u_0 free
        prog.add_eq([(col(e, WP + i), 1.0) for e in sources], p1[i])
        prog.add_eq([(col(e, WV + i), 1.0) for e in sources] + [(u0 + i, -gain)], keep * v0[i])
        prog.add_eq([(col(e, WU + i), 1.0) for e in sources] + [(u0 + i, -1.0)])
        prog.add_le([(u0 + i, 1.0)], f_max)
        prog.add_le([(u0 + i, -1.0)], f_max)
    for c in geom.speed_dirs:
        prog.add_le([(u0, gain * c[0]), (u0 + 1, gain * c[1])], geom.speed_bound - keep * (c @ v0))
    for e, (tr, tk, _, hk) in enumerate(edges):
        phi = (col(e, PHI), 1.0)
        prog.add_le([(col(e, PHI), -1.0)])
        for i in range(2):
            p = head(e, "p", i)
            prog.add_le([(c, -v) for c, v in p] + [(col(e, PHI), rects[hk, 0, i])])
            prog.add_le(p + [(col(e, PHI), -rects[hk, 1, i])])
            if tr >= 0:
                prog.add_le([(col(e, WP + i), -1.0), (col(e, PHI), rects[tk, 0, i])])
                prog.add_le([(col(e, WP + i), 1.0), (col(e, PHI), -rects[tk, 1, i])])
            prog.add_le([(col(e, MU + i), 1.0), (col(e, PHI), -f_max)])
            prog.add_le([(col(e, MU + i), -1.0), (col(e, PHI), -f_max)])
        for c in geom.speed_dirs:
            prog.add_le([(k, c[0] * v) for k, v in head(e, "v", 0)] + [(k, c[1] * v) for k, v in head(e, "v", 1)]
                        + [(col(e, PHI), -geom.speed_bound)])
        s = 2.0 * np.sqrt(rho)  # t phi >= rho |u - u_prev|^2  <=>  ||(2 sqrt(rho)(u - u_prev), t - phi)|| <= t + phi
        prog.add_cone([[(col(e, TT), 1.0), phi], [(col(e, MU), s), (col(e, WU), -s)],
                       [(col(e, MU + 1), s), (col(e, WU + 1), -s)], [(col(e, TT), 1.0), (col(e, PHI), -1.0)]])
    into, out = defaultdict(list), defaultdict(list)
    for e, (tr, tk, hr, hk) in enumerate(edges):
        into[hr, hk].append(e)
        if tr >= 0:
            out[tr, tk].append(e)
    for r, k in set(into) | set(out):  # conservation of flow and state through every inner vertex
        if r == horizon - 2:
            continue
        ins, outs = into[r, k], out[r, k]
        prog.add_eq([(col(e, PHI), 1.0) for e in ins] + [(col(e, PHI), -1.0) for e in outs])
        for part, base in (("p", WP), ("v", WV), ("u", WU)):
            for i in range(2):
                prog.add_eq([t for e in ins for t in head(e, part, i)] + [(col(e, base + i), -1.0) for e in outs])
    for qi, k in enumerate(last):  # q >= |P - phi G|^2 / phi per final vertex
        ins = into[horizon - 2, k]
        phis = [(col(e, PHI), 1.0) for e in ins]
        rows = [[(q0 + qi, 1.0)] + phis]
        for i in range(2):
            centre = [(col(e, PHI), -2 * goal[i]) for e in ins]
            rows.append([(c, 2 * v) for e in ins for c, v in head(e, "p", i)] + centre)
        rows.append([(q0 + qi, 1.0)] + [(c, -1.0) for c, _ in phis])
        prog.add_cone(rows)
    cost = np.zeros(n)
    cost[[col(e, TT) for e in range(n_e)]] = 1.0
    cost[q0:] = 1.0
    t0 = time.perf_counter()
    value, status = prog.solve(n, cost)
    return {"gcs": value, "status": status, "relaxation": relax.f, "edges": n_e, "rectangles": len(rects),
            "seconds": time.perf_counter() - t0}


def city(seed: int, k: int, n: int, folder: Path) -> Path:
    gen = replace(generate(seed, k, n, kind="city"), name=f"city-s{seed}", seed=seed)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / f"city-s{seed}.world.toml").write_text(world_toml(gen))
    (folder / f"city-s{seed}.toml").write_text(mission_toml(gen, f"city-s{seed}.world.toml"))
    return folder / f"city-s{seed}.toml"


def table(rows: list[dict]) -> str:
    head = ["mission", "target", "optimum (m^2)", "obstacle-free QP / optimum", "GCS / optimum", "GCS seconds", "edges"]
    cells = [[r["mission"], r["target"], f"{r['optimum']:.1f}", f"{r['relaxation'] / max(r['optimum'], 1.0):.3f}",
              f"{r['gcs'] / max(r['optimum'], 1.0):.3f}", f"{r['seconds']:.2f}", r["edges"]] for r in rows]
    return markdown_table(head, cells)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cities", default="11:50:8", help="comma-separated SEED:BUILDINGS:TARGETS")
    ap.add_argument("--targets", type=int, default=4, help="targets per mission (the first ones)")
    ap.add_argument("--budget", type=float, default=300.0, help="nominal seconds of the solver's certified optimum")
    ap.add_argument("--out", default="runs/gcs")
    ap.add_argument("--report", metavar="JSON", help="print the markdown table of a finished run and stop")
    args = ap.parse_args()
    if args.report:
        print(table(json.loads(Path(args.report).read_text())["rows"]))
        return
    started, rows = machine(), []
    out = Path(args.out)
    missions = [Path(__file__).resolve().parents[1] / "missions" / "paper.toml"]
    missions += [city(*map(int, c.split(":")), out / "cities") for c in args.cities.split(",") if c]
    print(f"{'mission':<16}{'target':>7}{'optimum':>11}{'relax/opt':>10}{'GCS/opt':>9}{'GCS s':>8}{'edges':>7}")
    for path in missions:
        m = load_mission(path)
        g = Guidance(m.world, m.dynamics, replace(m.guidance, time_limit=args.budget))
        rects = rectangles(g.geom.lo, g.geom.hi, g.geom.area_lo, g.geom.area_hi)
        for t in m.targets[:args.targets]:
            goal = m.world.goals[t.goal].centroid[:2]
            plan = g.plan(t.mean0, t.cov0, m.world.goals[t.goal].centroid)
            row = {"mission": path.stem, "target": t.name, "optimum": plan.objective, "status": plan.status,
                   **gcs_bound(g, t.mean0[[0, 1, 3, 4]], goal, plan.objective * (1 + 1e-6), rects)}
            rows.append(row)
            opt = max(plan.objective, 1.0)
            print(f"{path.stem:<16}{t.name:>7}{plan.objective:>11.1f}{row['relaxation'] / opt:>10.3f}"
                  f"{row['gcs'] / opt:>9.3f}{row['seconds']:>8.2f}{row['edges']:>7}", flush=True)
    write(out / "gcs.json", {"settings": vars(args), "rows": rows}, started)
    print(f"wrote {out / 'gcs.json'}")


if __name__ == "__main__":
    main()
