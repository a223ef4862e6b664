"""Exact solution of Problem (P1) within a budget: QP branch-and-bound, outer approximation.

P1's objective is ``f = sum_k w_k s_k^2`` over affine terms ``s`` (terminal error e,
control increments d) on a mixed-binary polyhedron.  Every solve, counting its QPs
against a :class:`Budget`:

1. finds upper bounds: QPs with the faces fixed (:mod:`.qp`) for the previous plan's
   faces; for a first plan, the faces along the shortest topologically distinct routes
   round the inflated obstacles (:mod:`uavsim.world.routes`); two dives from the obstacle-free
   optimum; a corner local search.  A world (or a start) whose obstacle-free optimum is
   clear of every obstacle is solved by that one QP;
2. certifies the best by a best-first branch-and-bound over the faces the reachable set
   of plans with ``f <= UB`` leaves undecided, each node a QP
   (:meth:`OuterApproximation._branch`).  Stopped by the budget, it reports the least
   bound of its open nodes: the plan's certified gap (status "feasible" above tolerance);
3. only where ``bnb_nodes`` caps that tree (a cross-check of the method), outer
   approximation (OA) alternates two problems until the gap closes:

* **master (HiGHS MILP, lower bound).**  Each ``s_k^2`` becomes an epigraph variable
  ``t_k >= 2 a s_k - a^2`` (tangent cuts); ``sum_k w_k t_k <= f`` everywhere, so the
  master optimum bounds P1 from below.  Cuts involve ``s`` only, never the start state,
  so every cut ever made stays valid at later re-plans.
* **QP with the faces fixed (upper bound)**, :mod:`.qp`: a feasible plan.  Once its
  optimum ``s*`` is cut into the master, the master values that face choice at exactly
  ``f(s*)`` (the tangent plane at ``s*`` is minimised at ``s*`` over the same convex set),
  so no face choice comes back and the loop is finite.

On the two hardest first plans of generated worlds we met (seeds 12 and 31, a target
behind walls), the tree certified the optimum with about 500-600 QPs (5-6 s under load)
where one HiGHS master MILP ran 100 s, so the tree is the default engine and the master
a tested alternative.  Gaps are ``(UB - LB) / max(UB, 1)`` (objective in m^2: near zero
the gap is absolute in m^2).

Starts inside an inflated obstacle (an estimate can be; a start against a wall can be
unable to leave the margin in time): where no reachable point is beyond any face of an
obstacle at some step (:func:`.faces.stuck_pairs`), that avoidance constraint is dropped
at that step, so the plan leaves as soon as the force limit allows; the plan says so.

What makes the tree and the master fast (measured on the paper mission):

* an upper bound before any branching (step 1 above, :func:`.faces.extend_faces`);
* binaries fixed where the reachable set decides them (:func:`.faces.prune`), big-M per
  step tightened to the reachable set (:func:`.faces.tight_big_m`), and ``|s_k| <=
  sqrt(UB / w_k)``.  The backward part of the reachable set and the bounds on ``s`` hold
  for every plan with ``f <= UB``, the optimum included; a problem restricted to them is
  still a relaxation of "P1 with f <= UB", so its optimum is still a valid lower bound
  whenever it is below UB;
* the master gets the bound as a cutoff (``objective_bound``): an infeasible master
  proves optimality.  HiGHS's feasibility-jump heuristic is switched off in the master,
  because with a cutoff it can return a solution above the cutoff and a wrong dual bound
  (highspy 1.15.1); a cutoff run is trusted only as "infeasible" or "optimal below the
  cutoff".
"""

from __future__ import annotations

import heapq
import itertools
import time
from dataclasses import dataclass, replace

import highspy
import numpy as np
import scipy.sparse as sp

from .compiled import INF, Compiled, new_highs, pass_model
from .faces import (
    Reach,
    beyond,
    binding_faces,
    choose_faces,
    extend_faces,
    inside,
    prune,
    redundant,
    stuck_pairs,
    tight_big_m,
)
from .model import Geometry
from .qp import WORK_ITERATION_S, FixedFaceQP, QpSolution

_STATUS = highspy.HighsModelStatus
E_GRID = np.array([0.05, 0.2, 0.5, 1.0])  # initial tangent points, as fractions of |s_k|'s bound
NO_PLAN_AT_ALL = "no plan meets the speed, force and area limits even without obstacles"
UNREACHABLE = "the goal region cannot be reached within the horizon under the speed, force and area limits"
NO_SAFE_ARRIVAL = "no collision-free plan ends in the goal region within the horizon"
ROUTES = 3  # topologically distinct shortest routes that seed the face choices of a first plan
PACES = (1.0, 0.8, 0.6)  # progress profiles along a route, fractions of the farthest the target can go


MAX_OPEN_NODES = 500_000  # a tree this wide stops with its bound (about 1 GB of nodes), as the budget does
NODE_SECONDS = 0.19e-3  # the work round one QP of the search (faces, reach boxes, branching), reference s

@dataclass
class Budget:
    """What one solve may spend: ``seconds`` of the reference machine.  Each fixed-face QP
    is charged what it costs there (:attr:`.qp.FixedFaceQP.work`: from its DAQP iterations
    and rows, and its Clarabel calls, not from the clock), so that a plan depends on its
    inputs only and not on the machine's speed or load (campaigns stay bit-identical for
    any number of workers).  A solve with no feasible plan yet keeps going past
    ``seconds`` up to ``need`` reference seconds, also counted in work.  ``deadline``
    (``time.perf_counter``) caps the wall clock as a safety net only, far beyond what the
    work takes, and ``capped`` records that it, not the work, stopped the solve (the plan
    may then differ on another machine).  ``master``: whether the MILP master may run
    (HiGHS's work is bounded by time only, so only cold plans use it)."""

    seconds: float
    deadline: float
    master: bool = False
    capped: bool = False
    spent: float = 0.0  # reference seconds charged so far
    need: float = np.inf  # reference seconds a solve without a plan may spend

    def take(self, need: bool = False) -> bool:
        """Whether another QP may run: work left (or ``need``: no plan yet, and work left
        of ``need``), before the deadline."""
        if time.perf_counter() > self.deadline:
            self.capped = True
            return False
        return self.spent < (self.need if need else self.seconds)

    def charge(self, seconds: float) -> None:
        self.spent += seconds

    @property
    def left(self) -> bool:
        return self.spent < self.seconds and time.perf_counter() <= self.deadline


@dataclass(frozen=True, eq=False)
class Solution:
    """Result of one P1 solve (model units: m, m/s, kN).

    status : "optimal" (certified gap <= tolerance), "feasible" (a collision-free plan
    within the limits whose certified gap is above the tolerance: the budget ran out, or
    solver tolerances stopped progress; the message says which), "infeasible" (proved),
    "error" (no plan).
    """

    status: str
    objective: float
    lower_bound: float
    gap: float
    iterations: int
    plan: QpSolution | None
    message: str = ""
    work: float = 0.0  # reference seconds of the budget spent
    guarded_from: int = 2  # the first planned step whose avoidance rows all hold (later than 2: a start in a margin)


@dataclass(eq=False)
class _Context:
    """One solve's inputs, shared by its pieces: row bounds ``lo, hi``, face offsets
    ``b (T-1, n, 4)``, ``stuck (T-1, n)`` pairs, ``needed (T-1, n)`` the pairs whose
    avoidance rows a QP needs (:func:`.faces.redundant`), the obstacle-free optimum, the
    start, the goal, the budget and the cut points met so far."""

    lo: np.ndarray
    hi: np.ndarray
    b: np.ndarray
    stuck: np.ndarray
    needed: np.ndarray
    relax: QpSolution
    x0: np.ndarray
    goal: np.ndarray
    budget: Budget
    points: list
    box: tuple | None = None


class OuterApproximation:
    """P1 compiled once; :meth:`solve` for each new start state and goal.

    ``reference_plans`` (off): the plan returned is re-solved by Clarabel, the QP solver
    before DAQP (commit d6ed022; one more QP per plan, about 5 ms at T = 50, not counted in the
    budget), for numbers close to those of before; the search and the bounds stay DAQP's
    (the reported gap then includes Clarabel's error).
    Off, a plan is DAQP's verified optimum, which differs from Clarabel's by Clarabel's
    tolerance (objectives ~1e-8 relative; closed-loop summaries of
    ``tests/test_reference.py`` up to 2e-7).  Exact agreement is out of reach either way:
    where two face choices tie to ~1e-9, Clarabel's error decided which the search kept.
    """

    reference_plans = False

    def __init__(self, c: Compiled, geom: Geometry, reach: Reach, gap: float, bnb_nodes: int | None = None):
        self.geom, self.reach, self.gap = geom, reach, gap
        self.bnb_nodes = bnb_nodes  # QPs the branch-and-bound may solve before OA takes over (None: the budget)
        self.c = c
        self.qp = FixedFaceQP(self.c)
        self.offsets = geom.face_offsets
        self.faces = geom.faces
        self.shape = (reach.horizon - 1, *self.offsets.shape)
        c, k = self.c, len(self.c.term_cols)
        self.a_master = sp.hstack([c.a, sp.csr_matrix((c.a.shape[0], k))]).tocsr()
        self.a_master.sort_indices()
        # positions of the big-M coefficients in a_master.data, and their binaries
        rows = np.repeat(np.arange(c.a.shape[0]), np.diff(self.a_master.indptr))
        is_y = np.isin(self.a_master.indices, c.y_cols.ravel()) & (c.row_y[rows] >= 0)
        self.m_pos = np.flatnonzero(is_y)
        self.m_flat = c.row_y[rows[is_y]]
        self.m_model = np.broadcast_to(geom.big_m[None], self.shape).reshape(-1)
        self.cost = np.r_[np.zeros(c.n_cols), c.term_w]
        self.integrality = np.zeros(c.n_cols + k)
        self.integrality[c.y_cols.ravel()] = 1

    # ------------------------------------------------------------------ public
    def solve(self, x0: np.ndarray, goal: np.ndarray, budget: Budget,
              warm: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
              box: tuple[np.ndarray, np.ndarray] | None = None, applied: np.ndarray | None = None) -> Solution:
        """Solve P1 from ``x0 = [p_x, p_y, v_x, v_y]`` towards ``goal (2,)`` within ``budget``;
        ``applied (2,)``: the force applied last (kN), which only a program with the link
        term reads (:class:`.model.GuidanceConfig`).

        ``box = (lo (2,), hi (2,))``: a hard terminal, ``p_T`` in that region (the area
        rows of ``p_T`` are tightened to it); a proof that no plan ends there says so in
        the message (:data:`UNREACHABLE`, :data:`NO_SAFE_ARRIVAL`).

        ``warm = (y, s, points)``: an earlier plan's faces ``(T-1, n, 4)``, terms ``(K,)``
        and positions ``(T-1, 2)``, shifted to this solve's steps; the faces are tried first
        and the terms seed the cuts.  The
        solver keeps no other state: a solve depends on its arguments (and, only when the
        wall-clock cap stops it, on time).

        A start inside or against an inflated obstacle can leave no collision-free plan
        even where every single step could be outside it (the steps cannot all be at
        once).  Then the obstacles within one step's travel of the first planned position
        are dropped for the first 1, 2, 4, ... steps until a plan exists; the plan says
        from which step it avoids them, as for :func:`.faces.stuck_pairs`.
        """
        theta = np.r_[x0, goal, np.zeros(2) if applied is None else applied]
        sol = self._solve(theta, budget, warm, 0, box=box)
        p1 = x0[:2] + self.reach.dt * x0[2:]
        reach = self.reach.v_max * self.reach.dt
        near = np.all((p1 >= self.geom.lo - reach) & (p1 <= self.geom.hi + reach), axis=1)  # (n,)
        escape = 1
        while (sol.status == "infeasible" and sol.message not in (NO_PLAN_AT_ALL, UNREACHABLE) and near.any()
               and escape < self.shape[0]):
            sol = self._solve(theta, budget, warm, escape, near, box)
            escape *= 2
        return replace(sol, work=budget.spent)

    def _solve(self, theta, budget, warm, escape: int, near: np.ndarray | None = None, box=None) -> Solution:
        """:meth:`solve` at the parameters ``theta = [x0, goal, applied]`` with the obstacles
        ``near (n,)`` dropped for the first ``escape`` steps."""
        x0, goal = theta[:4], theta[4:6]
        b = np.broadcast_to(self.offsets[None], self.shape)  # face offsets of every step
        lo, hi = self.c.rows(theta)
        if box is not None:
            rows = self.c.terminal_rows
            lo[rows], hi[rows] = np.maximum(lo[rows], box[0]), np.minimum(hi[rows], box[1])
        relax = self.qp.solve(lo, hi, np.ones(self.shape), relax=True)
        if relax is None:
            why = NO_PLAN_AT_ALL if box is None else UNREACHABLE
            return Solution("infeasible", np.inf, np.inf, np.inf, 0, None, why)
        if self.shape[1] == 0:  # no obstacle on the ground: P1 is the QP
            relax = self._reference(lo, hi, relax)
            return Solution("optimal", relax.f, relax.f, 0.0, 0, relax)
        valid = self.faces.valid
        fb = self.reach.face_bounds(x0, goal, self.faces.normals, box=box)
        face_lo, face_hi = fb.lo, fb.hi
        stuck = stuck_pairs(face_hi, b, valid)
        if escape:
            stuck[:escape, near] = True
        needed = ~redundant(face_lo, b, valid) & ~stuck
        if not np.any((inside(relax.x[2:, :2], self.faces, b) > 1e-7) & ~stuck):  # the obstacle-free optimum is clear
            y = choose_faces(relax.x[2:, :2], self.faces, b, *prune(face_lo, face_hi, b, valid, stuck))
            plan = self._reference(lo, hi, replace(relax, y=y))
            return self._noted(Solution("optimal", plan.f, min(relax.f, plan.f), 0.0, 0, plan), stuck, budget)
        f = self.shape[2]
        hi[self.c.sum_rows] = np.where(stuck.reshape(-1), f, f - 1.0)  # Eq. (8e) off for stuck pairs
        bounds = prune(face_lo, face_hi, b, valid, stuck)
        ctx = _Context(lo, hi, b, stuck, needed, relax, x0, goal, budget,
                       [relax.s] + ([warm[1]] if warm is not None else []), box)
        best = self._upper_bound(ctx, warm, bounds)
        sol = self._loop(ctx, best)
        if sol.plan is not None:
            plan = self._reference(lo, hi, sol.plan)
            lower = min(sol.lower_bound, plan.f)
            sol = replace(sol, objective=plan.f, lower_bound=lower, gap=max(plan.f - lower, 0.0) / max(plan.f, 1.0),
                          plan=plan)
        return self._noted(sol, stuck, budget)

    def _noted(self, sol: Solution, stuck: np.ndarray, budget: Budget) -> Solution:
        """``sol`` with what a plan must tell its reader: avoidance dropped at early steps,
        a wall-clock stop."""
        notes, guarded = [sol.message] if sol.message else [], 2
        if stuck.any() and sol.plan is not None:
            names = ", ".join(f"'{self.geom.names[k]}'" for k in np.flatnonzero(stuck.any(axis=0)))
            guarded = int(np.flatnonzero(stuck.any(axis=1))[-1]) + 3
            notes.append(f"start inside the margin of {names}: avoided from step {guarded}")
        if budget.capped:
            notes.append("stopped by the wall-clock cap, not the work budget: may differ on another machine")
        return replace(sol, message="; ".join(notes), guarded_from=guarded)

    def _reference(self, lo, hi, plan: QpSolution) -> QpSolution:
        """The plan returned: with :attr:`reference_plans`, Clarabel's solution of the QP
        that gave it (:meth:`.qp.FixedFaceQP.reference`)."""
        return self.qp.reference(lo, hi, plan) if self.reference_plans else plan

    def with_faces(self, x0: np.ndarray, goal: np.ndarray, y: np.ndarray,
                   box: tuple[np.ndarray, np.ndarray] | None = None,
                   applied: np.ndarray | None = None) -> QpSolution | None:
        """P1 from ``x0`` (``applied``: see :meth:`solve`) with the face choice ``y (T-1, n,
        F)`` fixed: one QP (None if it has no plan).  Where ``y`` is the optimal choice of a
        nearby start, this is the optimum's branch of P1, which is piecewise affine in the start."""
        lo, hi = self.c.rows(np.r_[x0, goal, np.zeros(2) if applied is None else applied])
        if box is not None:
            rows = self.c.terminal_rows
            lo[rows], hi[rows] = np.maximum(lo[rows], box[0]), np.minimum(hi[rows], box[1])
        return self.qp.solve(lo, hi, y)

    # ------------------------------------------------------------------ pieces
    def _charged(self, ctx: "_Context", y: np.ndarray, **kw) -> QpSolution | None:
        """The fixed-face QP for ``y`` at the solve's parameters, its work charged to the budget."""
        before = self.qp.work
        sol = self.qp.solve(ctx.lo, ctx.hi, y, **kw)
        ctx.budget.charge(self.qp.work - before + NODE_SECONDS)
        return sol

    def _qp(self, ctx: "_Context", y: np.ndarray, best: QpSolution | None) -> QpSolution | None:
        """The fixed-face QP, if the budget allows (always while no plan exists yet)."""
        if not ctx.budget.take(need=best is None):
            return None
        sol = self._charged(ctx, y, needed=ctx.needed)
        if sol is not None:
            ctx.points.append(sol.s)
        return sol

    def _upper_bound(self, ctx: "_Context", warm, bounds) -> QpSolution | None:
        """Best plan among: the previous plan's faces (or, where they no longer fit the
        reachable set, the faces its shifted points lie beyond), and two dives from the
        obstacle-free optimum (:func:`.faces.extend_faces`, nearest side and runner-up side).
        Each is polished by re-reading the faces off its plan while that improves it; then
        a local search at the corners.  Stops early when the budget runs out with a plan."""
        best = None
        if warm is not None:
            y = warm[0] if self._fits(warm[0], bounds) else choose_faces(warm[2], self.faces, ctx.b, *bounds)
            best = self._polish(ctx, self._qp(ctx, y, best), best, bounds)
        if warm is None or best is None:
            for y in self._route_faces(ctx, bounds):
                best = self._polish(ctx, self._qp(ctx, y, best), best, bounds)
        for rank in (0, 1):
            if best is not None and not ctx.budget.left:
                break
            best = self._polish(ctx, self._dive(ctx, bounds, rank, best), best, bounds)
        return self._corner_search(ctx, best, bounds) if best is not None else None

    def _route_faces(self, ctx, bounds) -> list[np.ndarray]:
        """Face choices along the :data:`ROUTES` shortest topologically distinct routes
        round the inflated obstacles (:meth:`uavsim.world.routes.Visibility.distinct_routes`), from the first
        planned position to the goal.  Step tau is placed on a route by a progress profile:
        at the fraction of the route the obstacle-free optimum has covered by then (same
        speed profile, longer path), and at :data:`PACES` of the farthest the target can
        have come by then (:meth:`.faces.Reach.progress`; a route longer than the horizon's
        reach, where the first profile runs ahead of what the force limit allows, needs
        these); each step takes, per obstacle, the allowed face that point is most clearly
        beyond.  Dives from the straight line find only the detours nearest to it; a route
        round the far side of a wall, or through a corridor, comes from here."""
        g, x = self.geom, ctx.relax.x[1:, :2]  # planned positions of steps 1..T
        routes = g.visibility.distinct_routes(x[0], ctx.goal, k=ROUTES)
        cum = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(x, axis=0), axis=1))]
        frac = cum[1:] / cum[-1] if cum[-1] > 1e-9 else np.linspace(0.0, 1.0, len(cum))[1:]
        out = []
        for r in routes:
            ahead = r.points[min(1, len(r.points) - 1)] - r.points[0]
            progress = self.reach.progress(ctx.x0, ahead)[2:] - self.reach.progress(ctx.x0, ahead)[1]
            profiles = [frac * r.length] + [np.minimum(pace * progress, r.length) for pace in PACES]
            out += [choose_faces(r.at(s), self.faces, ctx.b, *bounds) for s in profiles]
        return out

    def _polish(self, ctx, inc, best, bounds, rounds=3) -> QpSolution | None:
        """Re-read the faces off a plan and re-solve while that improves on ``best``."""
        for _ in range(rounds):
            if inc is None or (best is not None and inc.f >= best.f * (1 - 1e-9)):
                break
            best = inc
            inc = self._qp(ctx, choose_faces(inc.x[2:, :2], self.faces, ctx.b, *bounds), best)
        return best

    def _corner_search(self, ctx, best, bounds, tries=12) -> QpSolution:
        """Local search at the corners: where the plan touches face i of an obstacle,
        try the two perpendicular faces at that step instead (a path rounding a corner
        one step earlier or later).  On the paper mission the start heuristics were
        suboptimal in 30% of re-plans, almost always by such a one-step corner shift."""
        tried = 0
        improved = True
        while improved and tried < tries and ctx.budget.left:
            improved = False
            for r, j, i in binding_faces(best.x[2:, :2], self.faces, best.y, ctx.b):
                for alt in self.faces.neighbours[j, i]:
                    if bounds[0][r, j, alt] != 0 or tried >= tries:
                        continue
                    y = best.y.copy()
                    y[r, j, :] = 1.0
                    y[r, j, alt] = 0.0
                    tried += 1
                    better = self._polish(ctx, self._qp(ctx, y, best), best, bounds)
                    if better is not best:
                        best, improved = better, True
                        break
                if improved:
                    break
        return best

    @staticmethod
    def _fits(y, bounds) -> bool:
        return bool(np.all((y >= bounds[0]) & (y <= bounds[1])))

    def _dive(self, ctx, bounds, rank, best, max_steps=12) -> QpSolution | None:
        """Switch faces on only where the current plan is inside an obstacle, re-solve,
        repeat until collision-free; then complete the choice with the faces the plan
        satisfies (its optimum does not change: those constraints are already met)."""
        y_lo, y_hi = bounds
        y = np.where(y_hi == 0, 0.0, 1.0)  # faces the pruning forces on
        sol = ctx.relax if not (y == 0).any() else self._qp(ctx, y, best)
        for _ in range(max_steps):
            if sol is None:
                return None
            nxt = extend_faces(y, sol.x[2:, :2], self.faces, ctx.b, y_lo, rank)
            if nxt is None:
                full = choose_faces(sol.x[2:, :2], self.faces, ctx.b, np.where(y == 0, 0.0, y_lo),
                                    np.where(y == 0, 0.0, y_hi))
                return replace(sol, y=full)
            y = nxt
            sol = self._qp(ctx, y, best)
        return None

    def _loop(self, ctx, best) -> Solution:
        """Certify the incumbent by branch-and-bound over the undecided faces within the
        budget; the outer-approximation master takes over only where ``bnb_nodes`` caps
        the tree (cold plans)."""
        best, lower, settled = self._branch(ctx, best)
        if best is None and settled:
            why = "no collision-free plan exists" if ctx.box is None else NO_SAFE_ARRIVAL
            return Solution("infeasible", np.inf, np.inf, np.inf, 0, None, why)
        if best is not None:
            tol = self.gap * max(best.f, 1.0)
            if settled or best.f - lower <= tol:
                return self._finish("optimal", best, max(lower, best.f - tol * (1 - 1e-9)), 0)
        if not ctx.budget.master or not ctx.budget.left:
            return self._finish("feasible", best, lower, 0, "work budget reached")
        return self._outer(ctx, best, lower)

    def _outer(self, ctx, best, lower) -> Solution:
        """Outer approximation: alternate the HiGHS master MILP (lower bound) and the QP
        with the master's faces fixed (upper bound) until the gap closes."""
        it = 0
        tried = [] if best is None else [best.y]  # face choices evaluated by the QP
        dead = []  # face choices whose QP is infeasible: excluded by no-good cuts
        while True:
            ub = best.f if best is not None else np.inf
            tol = self.gap * max(ub, 1.0)
            if best is not None and ub - lower <= tol:
                return self._finish("optimal", best, lower, it)
            remaining = ctx.budget.deadline - time.perf_counter()
            if remaining <= 0 or ctx.budget.spent >= (ctx.budget.seconds if best is not None else ctx.budget.need):
                ctx.budget.capped |= remaining <= 0
                return self._finish("feasible", best, lower, it, "budget reached")
            cutoff = ub - tol * (1 - 1e-9) if best is not None else np.inf  # round-off: reported gap <= tol
            master = self._master(ctx, ub, np.vstack(ctx.points), dead, remaining, cutoff, best)
            if master is None:  # the reachable set of plans with f <= UB is empty
                return self._finish("optimal", best, max(lower, cutoff), it)
            master.run()
            it += 1
            status = master.getModelStatus()
            info = master.getInfo()
            ctx.budget.charge(NODE_SECONDS + WORK_ITERATION_S * max(info.simplex_iteration_count, 0))
            beaten = status == _STATUS.kOptimal and info.objective_function_value >= cutoff
            if status == _STATUS.kInfeasible or beaten:
                if best is None:
                    why = "no collision-free plan exists" if ctx.box is None else NO_SAFE_ARRIVAL
                    return Solution("infeasible", np.inf, np.inf, np.inf, it, None, why)
                return self._finish("optimal", best, max(lower, cutoff), it)
            if status == _STATUS.kTimeLimit:
                ctx.budget.capped = True
                return self._finish("feasible", best, max(lower, info.mip_dual_bound), it, "budget reached")
            if status != _STATUS.kOptimal:
                return self._finish("feasible" if best is not None else "error", best, lower, it,
                                    f"master MILP: {master.modelStatusToString(status)}")
            lower = max(lower, info.mip_dual_bound)
            z = np.asarray(master.getSolution().col_value)
            y = np.round(z[self.c.y_cols.ravel()]).reshape(self.shape)
            if any(np.array_equal(y, t) for t in tried):  # no progress possible: report the gap
                return self._finish("optimal" if ub - lower <= tol else "feasible", best, lower, it,
                                    "master repeated a face choice (solver tolerances)")
            tried.append(y)
            ctx.points.append(z[self.c.term_cols])
            inc = self._charged(ctx, y, bound=True)  # an infeasible one becomes a no-good cut
            if inc is None:
                dead.append(y)
                continue
            ctx.points.append(inc.s)
            if best is None or inc.f < best.f:
                best = inc

    def _branch(self, ctx, best) -> tuple[QpSolution | None, float, bool]:
        """Certify (or improve, or find) the incumbent by an exact best-first
        branch-and-bound over the faces.

        Binaries the reachable set of plans with ``f <= UB`` does not decide are left
        out; a node's QP switches on only the faces branched so far, so its optimum bounds
        every completion from below.  The deepest violated (step, obstacle) pair is
        branched on, one child per reachable face; a violation-free node is a plan.  A
        node carries the reachable box of every step given its faces
        (:func:`.faces.beyond`); a child whose box empties is dropped without a QP (on a
        50-building city, 95-99% of the infeasible children, and their confirmations).
        Returns the best plan (None if none is known), a certified lower bound (the least
        bound of the open nodes) and whether the tree was settled (every open node bounds
        at or above the cutoff: the plan is optimal within the gap, or no plan exists).
        Spends the budget's QPs, or at most ``bnb_nodes`` of them when that is set.
        """
        ub = np.inf if best is None else best.f
        relaxed = None if best is None else (ctx.relax.x[2:, :2], ctx.relax.f)
        fb = self.reach.face_bounds(ctx.x0, ctx.goal, self.faces.normals, ub, relaxed, ctx.box)
        face_lo, face_hi, valid = fb.lo, fb.hi, self.faces.valid
        bounds = prune(face_lo, face_hi, ctx.b, valid, ctx.stuck)
        # a node's optimum below the cutoff is within the bounds, where these rows hold
        needed = ctx.needed & ~redundant(face_lo, ctx.b, valid)
        cutoff = np.inf if best is None else best.f - self.gap * max(best.f, 1.0) * (1 - 1e-9)
        if bounds is None:  # no plan with f <= UB beyond the incumbent
            return best, min(cutoff, ub), True
        y_lo, y_hi = bounds
        root = np.where(y_hi == 0, 0.0, 1.0)
        ticket = itertools.count()  # heap tie-breaker: nodes never compare their arrays
        # a node: its bound, a ticket, the faces it switches on beyond the root's (flat indices), its step
        # boxes and the speed rows its parent's QP needed: a few hundred bytes, where y itself is T n F floats
        heap, solved = [(ctx.relax.f, next(ticket), (), fb.boxes, None)], 0
        open_pair = (y_lo == 0).any(axis=2)  # pairs with a face to choose (not stuck)
        step = self.reach.v_max * self.reach.dt
        limit = np.inf if self.bnb_nodes is None else self.bnb_nodes
        while heap:
            bound = heap[0][0]
            if bound >= cutoff:
                return best, cutoff, True  # best-first: every open node bounds at or above the cutoff
            if solved >= limit or not ctx.budget.take() or len(heap) > MAX_OPEN_NODES:
                return best, bound, False
            _, _, on, boxes, speed = heapq.heappop(heap)
            y = root.copy()
            y.reshape(-1)[list(on)] = 0.0
            sol = self._charged(ctx, y, bound=True, needed=needed, speed=speed)
            solved += 1
            if sol is None or sol.f >= cutoff:
                continue
            ctx.points.append(sol.s)
            depth = np.where((y == 1).all(axis=2) & open_pair, inside(sol.x[2:, :2], self.faces, ctx.b), -np.inf)
            if not np.any(depth > 1e-7):  # violation-free: a better plan
                full = choose_faces(sol.x[2:, :2], self.faces, ctx.b, np.where(y == 0, 0.0, y_lo),
                                    np.where(y == 0, 0.0, y_hi))
                best = replace(sol, y=full)
                cutoff = best.f - self.gap * max(best.f, 1.0) * (1 - 1e-9)
                continue
            r, j = np.unravel_index(np.argmax(depth), depth.shape)
            for i in np.flatnonzero(y_lo[r, j] == 0):
                within = beyond(boxes, r, self.faces.normals[j, i], ctx.b[r, j, i], step)
                if within is None:
                    continue  # out of reach given the faces already on: infeasible without a QP
                flat = int(np.ravel_multi_index((r, j, i), y.shape))
                heapq.heappush(heap, (sol.f, next(ticket), (*on, flat), within, sol.speed))
        return best, min(cutoff, np.inf if best is None else best.f), True

    def _master(self, ctx, ub, points, dead, time_limit, cutoff, best) -> highspy.Highs | None:
        """The master MILP for the current upper bound: pruned binaries, per-step big-M,
        bounded terms, tangent cuts at ``points (P, K)`` and a grid, no-good cuts."""
        c = self.c
        fb = self.reach.face_bounds(ctx.x0, ctx.goal, self.faces.normals, ub, (ctx.relax.x[2:, :2], ctx.relax.f),
                                    ctx.box)
        face_lo, face_hi = fb.lo, fb.hi
        bounds = prune(face_lo, face_hi, ctx.b, self.faces.valid, ctx.stuck)
        if bounds is None:
            return None
        y_lo, y_hi = bounds
        a = self.a_master.copy()
        m_new = tight_big_m(face_lo, ctx.b).reshape(-1)
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
        pass_model(h, sp.vstack([a, cuts]).tocsr(), self.cost, col_lo, col_hi, np.r_[ctx.lo, cut_lo],
                   np.r_[ctx.hi, np.full(len(cut_lo), INF)], self.integrality)
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
            why = message or "no feasible plan found within the budget"
            return Solution("error", np.inf, lower, np.inf, it, None, why)
        gap = max(best.f - lower, 0.0) / max(best.f, 1.0)
        return Solution(status, best.f, lower, gap, it, best, message)
