"""Exact solution of Problem (P1): QP branch-and-bound, then outer approximation (OA).

P1's objective is ``f = sum_k w_k s_k^2`` over affine terms ``s`` (terminal error e,
control increments d) on a mixed-binary polyhedron.  Every solve:

1. finds an upper bound: QPs with the faces fixed (:mod:`.qp`) for the previous plan's
   faces, two dives from the obstacle-free optimum and a corner local search;
2. certifies it by a small branch-and-bound over the faces the reachable set of plans
   with ``f <= UB`` leaves undecided, each node a QP (:meth:`OuterApproximation._branch`);
   on the paper mission this settles every warm re-plan we measured;
3. if that tree outgrows its budget, runs OA, which alternates two problems:

* **master (HiGHS MILP, lower bound).**  Each ``s_k^2`` becomes an epigraph variable
  ``t_k >= 2 a s_k - a^2`` (tangent cuts); ``sum_k w_k t_k <= f`` everywhere, so the
  master optimum bounds P1 from below.  Cuts involve ``s`` only, never the start state,
  so every cut ever made stays valid at later re-plans.
* **QP with the faces fixed (upper bound)**, :mod:`.qp`: a feasible plan.  Once its
  optimum ``s*`` is cut into the master, the master values that face choice at exactly
  ``f(s*)`` (the tangent plane at ``s*`` is minimised at ``s*`` over the same convex set),
  so no face choice comes back and the loop is finite.

It stops when ``(UB - LB) / max(UB, 1) <= gap`` (objective in m^2: near zero the gap is
absolute in m^2).

What makes OA fast (largest effect first, measured on the paper mission):

* an upper bound before any MILP (step 1 above, :func:`.faces.extend_faces`);
* the master gets the bound as a cutoff (``objective_bound``): an infeasible master
  proves optimality.  HiGHS's feasibility-jump heuristic is switched off in the master,
  because with a cutoff it can return a solution above the cutoff and a wrong dual bound
  (highspy 1.15.1); a cutoff run is trusted only as "infeasible" or "optimal below the
  cutoff";
* binaries fixed where the reachable set decides them (:func:`.faces.prune`), big-M per
  step tightened to the reachable set (:func:`.faces.tight_big_m`), and ``|s_k| <=
  sqrt(UB / w_k)``.  The backward part of the reachable set and the bounds on ``s`` hold
  for every plan with ``f <= UB``, the optimum included; a master restricted to them is
  still a relaxation of "P1 with f <= UB", so its optimum is still a valid lower bound
  whenever it is below UB.
"""

from __future__ import annotations

import heapq
import itertools
import time
from dataclasses import dataclass, replace

import highspy
import numpy as np
import scipy.sparse as sp

from .compiled import INF, Compiled, compile_p1, new_highs, pass_model
from .faces import Reach, binding_faces, choose_faces, extend_faces, inside, prune, tight_big_m
from .model import P1
from .qp import FixedFaceQP, QpSolution

_STATUS = highspy.HighsModelStatus
E_GRID = np.array([0.05, 0.2, 0.5, 1.0])  # initial tangent points, as fractions of |s_k|'s bound
NEAR_WALL_STEPS = 4  # steps 2..5 keep only obstacle + clearance when the start is near a wall
BNB_NODES = 16  # QP branch-and-bound budget before handing over to the MILP master


@dataclass(frozen=True, eq=False)
class Solution:
    """Result of one P1 solve (model units: m, m/s, kN).

    status : "optimal" (certified gap <= tolerance), "time_limit" (feasible plan, gap
    above tolerance), "stalled" (feasible plan; solver tolerances stopped progress, gap
    reported), "infeasible" (proved), "error" (no plan).
    """

    status: str
    objective: float
    lower_bound: float
    gap: float
    iterations: int
    plan: QpSolution | None
    message: str = ""


class OuterApproximation:
    """P1 compiled once; :meth:`solve` for each new start state and goal."""

    def __init__(self, p1: P1, reach: Reach, gap: float, time_limit: float, bnb_nodes: int = BNB_NODES):
        self.p1, self.reach, self.gap, self.time_limit = p1, reach, gap, time_limit
        self.bnb_nodes = bnb_nodes  # QPs the branch-and-bound may solve before OA takes over
        self.c: Compiled = compile_p1(p1)
        self.qp = FixedFaceQP(self.c)
        self.offsets = p1.geom.face_offsets
        self.shape = (p1.horizon - 1, self.offsets.shape[0], 4)
        c, k = self.c, len(self.c.term_cols)
        self.a_master = sp.hstack([c.a, sp.csr_matrix((c.a.shape[0], k))]).tocsr()
        self.a_master.sort_indices()
        # positions of the big-M coefficients in a_master.data, and their binaries
        rows = np.repeat(np.arange(c.a.shape[0]), np.diff(self.a_master.indptr))
        is_y = np.isin(self.a_master.indices, c.y_cols.ravel()) & (c.row_y[rows] >= 0)
        self.m_pos = np.flatnonzero(is_y)
        self.m_flat = c.row_y[rows[is_y]]
        self.m_model = np.broadcast_to(p1.geom.big_m[None], self.shape).reshape(-1)
        self.cost = np.r_[np.zeros(c.n_cols), c.term_w]
        self.integrality = np.zeros(c.n_cols + k)
        self.integrality[c.y_cols.ravel()] = 1
        self.avoid_rows = np.flatnonzero(c.row_y >= 0)

    # ------------------------------------------------------------------ public
    def solve(self, x0: np.ndarray, goal: np.ndarray, warm: tuple[np.ndarray, np.ndarray] | None = None) -> Solution:
        """Solve P1 from ``x0 = [p_x, p_y, v_x, v_y]`` towards ``goal (2,)``.

        ``warm = (y, s)``: the previous plan's faces ``(T-1, n, 4)`` and terms ``(K,)``,
        shifted by one step; the faces are tried first and the terms seed the cuts.  The
        solver keeps no other state: a solve depends on its arguments only.
        """
        t_end = time.perf_counter() + self.time_limit
        p1_pos = x0[:2] + self.reach.dt * x0[2:]
        b, shrink = self._offsets(p1_pos)
        lo, hi = self.c.rows(np.r_[x0, goal])
        hi = hi + shrink  # Eq. (8d) rows read -(a . p) - M y <= -b
        relax = self.qp.solve(lo, hi, np.ones(self.shape), relax=True)
        if relax is None:
            return Solution("infeasible", np.inf, np.inf, np.inf, 0, None,
                            "no plan meets the speed, force and area limits even without obstacles")
        bounds = prune(*self.reach.face_bounds(x0, goal), b)
        if bounds is None:
            return Solution("infeasible", np.inf, relax.f, np.inf, 0, None,
                            "at some step every reachable point is inside an inflated obstacle")
        points = [relax.s] + ([warm[1]] if warm is not None else [])
        best = self._upper_bound(lo, hi, relax, None if warm is None else warm[0], bounds, b, points)
        sol = self._loop(best, relax, (lo, hi), goal, x0, points, b, t_end)
        if shrink.any() and sol.plan is not None:
            sol = replace(sol, message=(sol.message + "; " if sol.message else "")
                          + f"start near a wall: steps 2-{NEAR_WALL_STEPS + 1} keep only the clearance margin")
        return sol

    def _offsets(self, p1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Face offsets ``b (T-1, n, 4)`` of every step, and the per-row relaxation.

        A start within one step of travel of an inflated obstacle may be unable to stay
        out of the full margin (it is there to make segments safe, see :mod:`.model`).
        For that obstacle, steps 2..``NEAR_WALL_STEPS + 1`` then only keep clear of the
        obstacle by the clearance; later steps have the full margin again.
        """
        g = self.p1.geom
        reach = self.reach.v_max * self.reach.dt
        near = np.all((p1 >= g.lo - reach) & (p1 <= g.hi + reach), axis=1)  # (n,)
        cut = np.zeros(self.shape[:2])
        cut[:NEAR_WALL_STEPS, near] = g.margin - g.clearance
        b = self.offsets[None, :, :] - cut[:, :, None]
        shrink = np.zeros(self.c.a.shape[0])
        rows = self.avoid_rows
        shrink[rows] = cut.reshape(-1)[self.c.row_y[rows] // 4]
        return b, shrink

    # ------------------------------------------------------------------ pieces
    def _upper_bound(self, lo, hi, relax, warm_y, bounds, b, points) -> QpSolution | None:
        """Best plan among: the warm face choice, and two dives from the obstacle-free
        optimum (:func:`.faces.extend_faces`, nearest side and runner-up side).  Each is
        polished by re-reading the faces off its plan while that improves it.  Every plan
        met on the way appends its terms to ``points`` (cut points for the master)."""
        y_lo, y_hi = bounds
        candidates = [self.qp.solve(lo, hi, warm_y)] if warm_y is not None and self._fits(warm_y, bounds) else []
        candidates += [self._dive(lo, hi, relax, bounds, b, rank) for rank in (0, 1)]
        best = None
        for inc in candidates:
            best = self._polish(lo, hi, inc, best, bounds, b, points)
        return self._corner_search(lo, hi, best, bounds, b, points) if best is not None else None

    def _polish(self, lo, hi, inc, best, bounds, b, points, rounds=3) -> QpSolution | None:
        """Re-read the faces off a plan and re-solve while that improves on ``best``."""
        for _ in range(rounds):
            if inc is None:
                break
            points.append(inc.s)
            if best is not None and inc.f >= best.f * (1 - 1e-9):
                break
            best = inc
            inc = self.qp.solve(lo, hi, choose_faces(inc.x[2:, :2], b, *bounds))
        return best

    def _corner_search(self, lo, hi, best, bounds, b, points, budget=12) -> QpSolution:
        """Local search at the corners: where the plan touches face i of an obstacle,
        try the two perpendicular faces at that step instead (a path rounding a corner
        one step earlier or later).  On the paper mission the start heuristics were
        suboptimal in 30% of re-plans, almost always by such a one-step corner shift."""
        tried = 0
        improved = True
        while improved and tried < budget:
            improved = False
            for r, j, i in binding_faces(best.x[2:, :2], best.y, b):
                for alt in ((2, 3) if i < 2 else (0, 1)):
                    if bounds[0][r, j, alt] != 0 or tried >= budget:
                        continue
                    y = best.y.copy()
                    y[r, j, :] = 1.0
                    y[r, j, alt] = 0.0
                    tried += 1
                    better = self._polish(lo, hi, self.qp.solve(lo, hi, y), best, bounds, b, points)
                    if better is not best:
                        best, improved = better, True
                        break
                if improved:
                    break
        return best

    @staticmethod
    def _fits(y, bounds) -> bool:
        return bool(np.all((y >= bounds[0]) & (y <= bounds[1])))

    def _dive(self, lo, hi, relax, bounds, b, rank, max_steps=12) -> QpSolution | None:
        """Switch faces on only where the current plan is inside an obstacle, re-solve,
        repeat until collision-free; then complete the choice with the faces the plan
        satisfies (its optimum does not change: those constraints are already met)."""
        y_lo, y_hi = bounds
        y = np.where(y_hi == 0, 0.0, 1.0)  # faces the pruning forces on
        sol = relax if not (y == 0).any() else self.qp.solve(lo, hi, y)
        for _ in range(max_steps):
            if sol is None:
                return None
            nxt = extend_faces(y, sol.x[2:, :2], b, y_lo, rank)
            if nxt is None:
                full = choose_faces(sol.x[2:, :2], b, np.where(y == 0, 0.0, y_lo), np.where(y == 0, 0.0, y_hi))
                return replace(sol, y=full)
            y = nxt
            sol = self.qp.solve(lo, hi, y)
        return None

    def _loop(self, best, relax, rows, goal, x0, points, b, t_end) -> Solution:
        it, lower = 0, relax.f
        if best is not None:
            best, proved = self._branch(rows, goal, x0, best, relax, b, points, t_end)
            if proved:
                tol = self.gap * max(best.f, 1.0)
                return self._finish("optimal", best, max(lower, best.f - tol * (1 - 1e-9)), 0)
        tried = [] if best is None else [best.y]  # face choices evaluated by the QP
        dead = []  # face choices whose QP is infeasible: excluded by no-good cuts
        while True:
            ub = best.f if best is not None else np.inf
            tol = self.gap * max(ub, 1.0)
            if best is not None and ub - lower <= tol:
                return self._finish("optimal", best, lower, it)
            remaining = t_end - time.perf_counter()
            if remaining <= 0:
                return self._finish("time_limit", best, lower, it)
            cutoff = ub - tol * (1 - 1e-9) if best is not None else np.inf  # round-off: reported gap <= tol
            master = self._master(rows, goal, x0, ub, relax, np.vstack(points), dead, b, remaining, cutoff, best)
            if master is None:  # the reachable set of plans with f <= UB is empty
                return self._finish("optimal", best, max(lower, cutoff), it)
            master.run()
            it += 1
            status = master.getModelStatus()
            info = master.getInfo()
            beaten = status == _STATUS.kOptimal and info.objective_function_value >= cutoff
            if status == _STATUS.kInfeasible or beaten:
                if best is None:
                    return Solution("infeasible", np.inf, np.inf, np.inf, it, None, "no collision-free plan exists")
                return self._finish("optimal", best, max(lower, cutoff), it)
            if status == _STATUS.kTimeLimit:
                return self._finish("time_limit", best, max(lower, info.mip_dual_bound), it)
            if status != _STATUS.kOptimal:
                return self._finish("error", best, lower, it, f"master MILP: {master.modelStatusToString(status)}")
            lower = max(lower, info.mip_dual_bound)
            z = np.asarray(master.getSolution().col_value)
            y = np.round(z[self.c.y_cols.ravel()]).reshape(self.shape)
            if any(np.array_equal(y, t) for t in tried):  # no progress possible: report the gap
                return self._finish("optimal" if ub - lower <= tol else "stalled", best, lower, it,
                                    "master repeated a face choice (solver tolerances)")
            tried.append(y)
            inc = self.qp.solve(*rows, y)
            points.append(z[self.c.term_cols])
            if inc is None:
                dead.append(y)
                continue
            points.append(inc.s)
            if best is None or inc.f < best.f:
                best = inc

    def _branch(self, rows, goal, x0, best, relax, b, points, t_end):
        """Certify (or improve) the incumbent by a small exact branch-and-bound.

        Binaries the reachable set of plans with ``f <= UB`` does not decide are left
        out; a node's QP switches on only the faces branched so far, so its optimum bounds
        every completion from below.  The deepest violated (step, obstacle) pair is
        branched on, one child per reachable face; a violation-free node is a plan.  When
        the open nodes all bound at or above the cutoff, the incumbent is optimal within
        the gap.  Cheap when few pairs are undecided (the usual warm re-plan, where the
        HiGHS master would spend ~0.2 s in root work); gives up after ``bnb_nodes`` QPs.
        Returns ``(best, proved)``.
        """
        lo, hi = rows
        bounds = prune(*self.reach.face_bounds(x0, goal, best.f, (relax.x[2:, :2], relax.f)), b)
        if bounds is None:
            return best, False
        y_lo, y_hi = bounds
        cutoff = best.f - self.gap * max(best.f, 1.0) * (1 - 1e-9)
        ticket = itertools.count()  # heap tie-breaker: nodes never compare their arrays
        heap, solved = [(relax.f, next(ticket), np.where(y_hi == 0, 0.0, 1.0))], 0
        while heap:
            bound, _, y = heapq.heappop(heap)
            if bound >= cutoff:
                return best, True  # best-first: every open node bounds at or above the cutoff
            if solved >= self.bnb_nodes or time.perf_counter() > t_end:
                return best, False
            sol = self.qp.solve(lo, hi, y)
            solved += 1
            if sol is None or sol.f >= cutoff:
                continue
            points.append(sol.s)
            depth = np.where((y == 1).all(axis=2), inside(sol.x[2:, :2], b), -np.inf)  # open pairs only
            if not np.any(depth > 1e-7):  # violation-free: a better plan
                full = choose_faces(sol.x[2:, :2], b, np.where(y == 0, 0.0, y_lo), np.where(y == 0, 0.0, y_hi))
                best = replace(sol, y=full)
                cutoff = best.f - self.gap * max(best.f, 1.0) * (1 - 1e-9)
                continue
            r, j = np.unravel_index(np.argmax(depth), depth.shape)
            for i in np.flatnonzero(y_lo[r, j] == 0):
                child = y.copy()
                child[r, j, i] = 0.0
                heapq.heappush(heap, (sol.f, next(ticket), child))
        return best, True

    def _master(self, rows, goal, x0, ub, relax, points, dead, b, time_limit, cutoff, best) -> highspy.Highs | None:
        """The master MILP for the current upper bound: pruned binaries, per-step big-M,
        bounded terms, tangent cuts at ``points (P, K)`` and a grid, no-good cuts."""
        c = self.c
        face_lo, face_hi = self.reach.face_bounds(x0, goal, ub, (relax.x[2:, :2], relax.f))
        bounds = prune(face_lo, face_hi, b)
        if bounds is None:
            return None
        y_lo, y_hi = bounds
        a = self.a_master.copy()
        m_new = tight_big_m(face_lo, b).reshape(-1)
        a.data[self.m_pos] *= m_new[self.m_flat] / self.m_model[self.m_flat]
        s_max = np.sqrt(ub / c.term_w) if np.isfinite(ub) else np.full(len(c.term_w), 1e4)
        grid = np.r_[-E_GRID[::-1], 0.0, E_GRID][:, None] * s_max[None, :]
        cuts, cut_lo = self._cuts(np.vstack([grid, points]))
        if dead:
            nogood, nogood_lo = self._nogoods(dead)
            cuts, cut_lo = sp.vstack([cuts, nogood]).tocsr(), np.r_[cut_lo, nogood_lo]
        k = len(c.term_cols)
        col_lo = np.r_[c.col_lo, np.zeros(k)]
        col_hi = np.r_[c.col_hi, np.full(k, INF)]
        col_lo[c.term_cols], col_hi[c.term_cols] = -s_max, s_max
        col_lo[c.y_cols.ravel()], col_hi[c.y_cols.ravel()] = y_lo.reshape(-1), y_hi.reshape(-1)
        # integrality tolerance 1e-9: at HiGHS's default 1e-6 a binary "at 0" switches a face
        # off by M * 1e-6 (~1e-3 m), enough for the master to undercut a cutoff on small objectives
        options = dict(mip_heuristic_run_feasibility_jump=False, mip_rel_gap=self.gap / 4, time_limit=time_limit,
                       mip_allow_restart=False, mip_feasibility_tolerance=1e-9)
        if best is not None:
            options |= dict(mip_heuristic_run_rins=False, mip_heuristic_run_rens=False, objective_bound=cutoff)
        h = new_highs(**options)
        lo, hi = rows
        pass_model(h, sp.vstack([a, cuts]).tocsr(), self.cost, col_lo, col_hi, np.r_[lo, cut_lo],
                   np.r_[hi, np.full(len(cut_lo), INF)], self.integrality)
        if best is not None and np.all((best.y >= y_lo) & (best.y <= y_hi)):
            cols = c.y_cols.ravel()
            h.setSolution(len(cols), cols, best.y.reshape(-1))
        return h

    def _cuts(self, points: np.ndarray) -> tuple[sp.csr_matrix, np.ndarray]:
        """Tangent cuts ``t_k - 2 a s_k >= -a^2`` at ``points (P, K)``: rows and lower bounds."""
        n_pts, k = points.shape
        rows = np.arange(n_pts * k)
        term = np.tile(np.arange(k), n_pts)
        a_pt = points.reshape(-1)
        cols = np.r_[self.c.n_cols + term, self.c.term_cols[term]]
        m = sp.csr_matrix((np.r_[np.ones(n_pts * k), -2.0 * a_pt], (np.r_[rows, rows], cols)),
                          shape=(n_pts * k, self.c.n_cols + k))
        return m, -(a_pt**2)

    def _nogoods(self, dead: list[np.ndarray]) -> tuple[sp.csr_matrix, np.ndarray]:
        """Rows excluding face choices: ``sum_{y*=0} y - sum_{y*=1} y >= 1 - |{y*=1}|``."""
        k = len(self.c.term_cols)
        ys = np.array([d.reshape(-1) for d in dead])
        coef = np.where(ys == 0, 1.0, -1.0)
        cols = np.tile(self.c.y_cols.ravel(), len(dead))
        rows = np.repeat(np.arange(len(dead)), ys.shape[1])
        m = sp.csr_matrix((coef.reshape(-1), (rows, cols)), shape=(len(dead), self.c.n_cols + k))
        return m, 1.0 - ys.sum(axis=1)

    def _finish(self, status, best, lower, it, message="") -> Solution:
        if best is None:
            why = message or "no feasible plan found in the time limit"
            return Solution("error", np.inf, lower, np.inf, it, None, why)
        gap = max(best.f - lower, 0.0) / max(best.f, 1.0)
        return Solution(status, best.f, lower, gap, it, best, message)
