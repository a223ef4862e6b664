"""The convex QP of P1 with the face choice fixed: the outer approximation's upper bound
and the branch-and-bound's node bound.

With every binary fixed, Eq. (8d) keeps only the active faces (``y = 1`` rows are
implied by the area bounds, because big-M is tight to the area) and P1 is a convex QP.

**Fast path: DAQP on the condensed QP** (:class:`Condensed`).  The equality rows (Eq.
8b-8c and the definitions of e and d) fix every column but the forces, ``z_O = S u +
P b_E``, so the QP is ``min 1/2 u'Hu + g'u + c0`` over the ``2T`` forces, with ``H``
(condition number ~1e3 on the paper mission) and the rows ``G u`` of the speed polygon,
area and active faces computed once per program; a solve only forms right-hand sides.
H is factorised once, ``H = R'R``, and DAQP ([Arnstrom2022]; a dual active-set method, exact at
convergence) solves it in ``w = R u``, where H is the identity, so its setup per QP is
one pass over the rows it keeps.

**Verified answers.**  Every optimum DAQP returns is checked in numpy before it is used:
the plan meets every kept row within :data:`FEAS_TOL`, and the Lagrangian dual value of
DAQP's multipliers (a lower bound on the optimum whatever their accuracy, weak duality)
is within :data:`GAP_TOL` of the plan's objective.  So a node bound of the
branch-and-bound is exact to ``GAP_TOL`` relative, far inside the certified gap (1e-4).
An infeasible verdict comes from DAQP's dual ray (the dual objective grows without
bound), which its interface does not return, so it is not checked here; on every
recorded QP of ``benchmarks/qp_solvers.py`` it agrees with Clarabel.  Where the verdict
bounds P1 (a branch-and-bound node is pruned, a no-good cut is made, or the obstacle-free
relaxation says no plan exists) Clarabel confirms it (``bound=True``); the heuristics'
infeasible verdicts only decide which incumbents are found (12 confirmations against
219 unconfirmed verdicts in 50 rolling re-plans of the paper mission's 4 targets).

**Fallback: Clarabel** (interior point, :class:`ClarabelQP`, the method before DAQP, commit d6ed022)
for anything the fast path cannot settle: a program that does not condense, an iteration
limit, cycling, or an answer that fails the checks; HiGHS's QP behind it.  A failure of
one solver is not a failure of the plan.

Measured (``benchmarks/qp_solvers.py``) on the 5761 QPs that 50 rolling re-plans
of the paper mission's 4 targets and of generated worlds 4, 12, 31 solve: every verdict
(982 infeasible) equal to Clarabel's, objectives within 5e-9 of Clarabel's (its own
tolerance) and within 3e-11 of Clarabel at 1e-11 tolerances, no fallback; median 0.4-0.9
ms CPU per QP against Clarabel's 6 ms.  Starting DAQP from the previous QP's working set
saved nothing here (paper mission: 11.0 DAQP iterations per QP on average against 10.3
cold; the median QP needs 3, and the faces change between QPs), so each QP starts cold
and depends on its arguments only.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, replace

import clarabel
import daqp
import highspy
import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from .compiled import Compiled, new_highs, pass_model

LOG = logging.getLogger(__name__)
_SOLVED = {"Solved", "AlmostSolved"}
_INFEASIBLE = {"PrimalInfeasible", "AlmostPrimalInfeasible"}
BIG = 1e30  # DAQP's infinity
FEAS_TOL = 1e-6  # largest row violation of a fast-path plan (m, m/s, kN)
GAP_TOL = 1e-9  # largest (objective - dual bound) / max(objective, 1) of a fast-path optimum
DAQP_SETTINGS = dict(primal_tol=1e-9, iter_limit=2000)
DAQP_OPTIMAL, DAQP_INFEASIBLE = 1, -1
LAZY_ROUNDS = 4  # rounds of adding violated speed rows before DAQP gets every row
LAZY_TOL = 1e-8  # a speed row violated by more (m/s) is added
# what a QP costs on the reference machine (2-core Intel Xeon), from what it did, not from the clock:
# per DAQP call, per row it was given and per iteration, and per Clarabel solve
# (benchmarks/budget.py --fit; docs/data/budget.json)
WORK_CALL_S, WORK_ROW_S, WORK_ITERATION_S, WORK_CLARABEL_S = 0.0, 2.3e-6, 2.2e-6, 10e-3


class SolverError(RuntimeError):
    """Both QP solvers failed on a fixed-face QP (not infeasibility: that is an answer)."""


@dataclass(frozen=True, eq=False)
class QpSolution:
    """A feasible plan for one face choice (model units).

    f : objective Eq. (7) in m^2; x : (T+1, 4) states; u : (T, 2) kN;
    s : (K,) squared-term values [e, d]; y : (T-1, n, 4) the face choice.
    solved : ``(y, relax)`` of the QP this plan solves (``y`` may later be completed
    with faces the plan already meets); by : "daqp" or "clarabel".
    """

    f: float
    x: np.ndarray
    u: np.ndarray
    s: np.ndarray
    y: np.ndarray
    solved: tuple | None = None
    by: str = "clarabel"
    speed: np.ndarray | None = None  # ids of the speed-polygon rows DAQP needed (a child's start)


class FixedFaceQP:
    """Solves P1 for a fixed face choice; the binaries are eliminated into the RHS.

    DAQP on the condensed QP, each answer verified, Clarabel where that fails (module
    docstring).  ``counts`` tallies how each QP was settled: "daqp" (verified optimum),
    "daqp infeasible", "clarabel" (fallback: DAQP could not settle it; logged),
    "confirmed infeasible" (a bound's infeasible verdict re-checked by Clarabel),
    "overruled" (Clarabel found a plan there: logged), "reference" (plans re-solved by
    :meth:`reference`).  A solve depends on its arguments only (no working set carries
    over), so plans stay reproducible.
    """

    def __init__(self, c: Compiled):
        self.c = c
        self.fallback = ClarabelQP(c)
        try:
            self.condensed = Condensed.build(c)
        except (ValueError, np.linalg.LinAlgError):
            self.condensed = None  # not the structure the fast path needs: Clarabel only
        self.counts = dict.fromkeys(("daqp", "daqp infeasible", "clarabel", "confirmed infeasible", "overruled",
                                     "reference"), 0)
        self.work = 0.0  # reference seconds of every QP solved so far (WORK_*), what budgets charge
        self._context = None

    def solve(self, lo: np.ndarray, hi: np.ndarray, y: np.ndarray, relax: bool = False,
              bound: bool = False, needed: np.ndarray | None = None, speed: np.ndarray | None = None
              ) -> QpSolution | None:
        """Optimal plan for face choice ``y (T-1, n, 4)`` and row bounds ``lo, hi`` (the
        current parameters).  ``relax`` drops Eq. (8d)-(8e) entirely: the obstacle-free
        QP, a relaxation of P1.  Returns None when the QP is infeasible.

        ``bound``: the verdict bounds P1 (a branch-and-bound node, a no-good cut), so an
        infeasible verdict of DAQP, which comes without a certificate, is confirmed by
        Clarabel (as is always the relaxation's, P1's own verdict).

        ``needed (T-1, n)`` bool: the fast path keeps avoidance rows only for these (step,
        obstacle) pairs; the caller vouches that the others' active faces hold at every
        plan it could use (in practice: at every plan within the reachable set, so the
        rows are redundant).

        ``speed``: ids of speed-polygon rows DAQP gets from the start (those a parent
        node's QP needed, :attr:`QpSolution.speed`) instead of adding them round by round;
        the optimum does not depend on it.
        """
        if self.condensed is not None:
            settled, sol = self._solve_daqp(lo, hi, y, relax, needed, speed)
            if settled and sol is not None:
                self.counts["daqp"] += 1
                return sol
            if settled and not (relax or bound):
                self.counts["daqp infeasible"] += 1
                return None
            if settled:
                self.work += WORK_CLARABEL_S
                ref = self.fallback.solve(lo, hi, y, relax, needed)
                self.counts["confirmed infeasible" if ref is None else "overruled"] += 1
                if ref is not None:
                    LOG.info("fixed-face QP: DAQP's infeasible verdict overruled by Clarabel (objective %.6g)", ref.f)
                return None if ref is None else replace(ref, solved=(y, relax))
            LOG.info("fixed-face QP: DAQP did not settle it; Clarabel solves it")
        self.counts["clarabel"] += 1
        self.work += WORK_CLARABEL_S
        sol = self.fallback.solve(lo, hi, y, relax, needed)
        return None if sol is None else replace(sol, solved=(y, relax))

    def reference(self, lo: np.ndarray, hi: np.ndarray, sol: QpSolution) -> QpSolution:
        """``sol`` as Clarabel solves the same QP (the plans of before DAQP, commit d6ed022, to its
        tolerance ~1e-8), keeping ``sol``'s face choice; ``sol`` itself where it already
        is Clarabel's or Clarabel finds no plan."""
        if sol.by == "clarabel" or sol.solved is None:
            return sol
        self.counts["reference"] += 1
        ref = self.fallback.solve(lo, hi, *sol.solved)
        return sol if ref is None else replace(ref, y=sol.y, solved=sol.solved)

    def _solve_daqp(self, lo, hi, y, relax, needed=None, speed=None) -> tuple[bool, QpSolution | None]:
        """``(settled, solution)``: settled is False where Clarabel must decide.

        The speed-polygon rows (800 of ~1200 on the paper mission, none active in most
        QPs) are added lazily: DAQP first sees the other rows; the speed rows the plan
        violates are added and DAQP restarts from its working set (at most
        :data:`LAZY_ROUNDS` rounds, then every row).  A QP without some rows is a
        relaxation, so its infeasibility is the QP's; its optimum, if it meets every row,
        is the QP's."""
        k = self.condensed
        if not relax and not np.all((y == 0) | (y == 1)):
            return False, None  # a fractional face choice shifts the kept rows: Clarabel
        ctx = self._context
        if ctx is None or not (np.array_equal(lo, ctx.lo) and np.array_equal(hi, ctx.hi)):
            if not np.array_equal(lo[k.eq], hi[k.eq]):
                return False, None  # an equality row given as a range: not the program condensed
            ctx = self._context = k.context(lo, hi)
        on = k.faces_on(y, relax, needed)
        f_lo, f_hi = ctx.a_lo[on], ctx.a_hi[on]
        if ctx.crossed or np.any(f_lo > f_hi):
            return False, None
        faces = (len(k.a_w) + on, k.face_rows(on), f_lo, f_hi)
        use = np.zeros(len(ctx.lazy_ids), bool) if speed is None else np.isin(ctx.lazy_ids, speed)
        working = np.zeros(0, int), np.zeros(0, np.intc)
        for attempt in range(LAZY_ROUNDS + 1):
            if attempt == LAZY_ROUNDS:
                use[:] = True
            sub, a, rlo, rhi = ctx.rows(use, *faces)
            flag, w, lam, working, iterations = _daqp(k, a, sub, rlo, rhi, ctx, working)
            self.work += WORK_CALL_S + WORK_ROW_S * len(sub) + WORK_ITERATION_S * iterations
            if flag != DAQP_OPTIMAL:
                return flag == DAQP_INFEASIBLE, None
            val = k.a_lazy @ w
            bad = ~use & ((val > ctx.lazy_hi + LAZY_TOL) | (val < ctx.lazy_lo - LAZY_TOL))
            if not bad.any():
                break
            use |= bad
        u = k.r_inv @ w
        z = k.s @ u + ctx.z0
        f = k.objective(z)
        if not k.verified(f, a, w, lam, rlo, rhi, ctx):
            return False, None
        y_out = np.ones_like(y) if relax else y
        return True, QpSolution(f, z[k.x_pos], u.reshape(k.u_shape), z[k.term], np.array(y_out, float),
                                (y, relax), "daqp", ctx.lazy_ids[use])


def _daqp(k: "Condensed", a, rows, rlo, rhi, ctx, working) -> tuple[int, np.ndarray, np.ndarray, tuple, int]:
    """DAQP on ``rlo <= a w <= rhi`` (``a`` the rows ``rows``, :meth:`Condensed.matrix`), started from
    ``working = (rows, sense)`` (the previous round's working set; sense 1 upper, 3 lower).
    Returns DAQP's flag, ``w``, the multipliers, the new working set and its iterations."""
    sense = np.zeros(len(rows), dtype=np.intc)
    was, side = working
    at = np.searchsorted(rows, was)
    hit = (at < len(rows)) & (rows[np.minimum(at, len(rows) - 1)] == was)
    sense[at[hit]] = side[hit]
    w, _, flag, info = daqp.solve(k.eye, ctx.lin_w, a, rhi, rlo, sense, **DAQP_SETTINGS)
    if flag != DAQP_OPTIMAL:
        return flag, w, np.zeros(0), working, info["iterations"]
    lam = np.asarray(info["lam"])
    on = np.flatnonzero(lam)
    return flag, w, lam, (rows[on], np.where(lam[on] > 0, 1, 3).astype(np.intc)), info["iterations"]


@dataclass(frozen=True, eq=False)
class _Context:
    """What the row bounds ``lo, hi`` (one start and goal) fix: ``z0 = P b_E``, the linear
    term in ``w`` (``lin_w = R^-T g``), the constant ``c0``, and the rows every QP of this
    start keeps: the forces with bounds and the general rows, as ids into :attr:`Condensed.a_w`
    with their bounds less the offset ``A_IO z0``, split into the ``core`` rows DAQP always
    gets (their matrix ``core_a`` gathered once here, not per QP) and the speed-polygon
    rows (``lazy_ids``, their matrix ``lazy_a``: :attr:`Condensed.a_lazy`); ``a_lo, a_hi``: the
    bounds of the avoidance row of each binary; ``crossed``: some kept row's lower bound is
    above its upper one."""

    lo: np.ndarray
    hi: np.ndarray
    z0: np.ndarray
    lin_w: np.ndarray
    c0: float
    core_ids: np.ndarray
    core_a: np.ndarray
    core_lo: np.ndarray
    core_hi: np.ndarray
    lazy_ids: np.ndarray
    lazy_a: np.ndarray
    lazy_lo: np.ndarray
    lazy_hi: np.ndarray
    a_lo: np.ndarray
    a_hi: np.ndarray
    crossed: bool

    def rows(self, lazy: np.ndarray, face_ids, face_a, face_lo, face_hi
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """A QP's rows: sorted ids, their matrix in ``w`` and bounds, of the core rows, the
        speed rows ``lazy`` (bool over :attr:`lazy_ids`) marks and the given avoidance rows
        (ids above every other row's)."""
        parts = [(self.core_ids, self.core_a, self.core_lo, self.core_hi)]
        if lazy.any():
            ids = np.concatenate([self.core_ids, self.lazy_ids[lazy]])
            order = np.argsort(ids, kind="stable")
            parts = [(ids[order], a[order], lo[order], hi[order]) for a, lo, hi in [(
                np.concatenate([self.core_a, self.lazy_a[lazy]]), np.concatenate([self.core_lo, self.lazy_lo[lazy]]),
                np.concatenate([self.core_hi, self.lazy_hi[lazy]]))]]
        parts.append((face_ids, face_a, face_lo, face_hi))
        return tuple(np.concatenate(p) for p in zip(*parts))


@dataclass(frozen=True, eq=False)
class Condensed:
    """P1 with the faces fixed and every column but the forces eliminated.

    The equality rows ``E`` (states, e, d; square, invertible) give ``z_O = S u + P b_E``
    for the other columns ``O``; the objective ``sum_k w_k z_O[term_k]^2`` becomes
    ``1/2 u'Hu + g'u + c0``.  Rows of :attr:`a_w` are every inequality in ``w = R u``
    (``H = R'R``): first one per force (its bounds), then the general rows ``rows``.

    Attributes
    ----------
    eq : (E,) equality rows; pinv : (E, E) ``P = A_EO^-1``; s : (E, n) ``S``.
    term, w : (K,) positions of the squared terms in ``z_O`` and their weights.
    x_pos : (T+1, 4) positions of the states in ``z_O``; u_shape : (T, 2).
    r_inv : (n, n) ``R^-1``; eye : (n, n).
    bound_rows, bound_coef : rows bounding one force each, and their coefficient;
    bound_of : (n, r) for each force the indices into bound_rows of its rows (-1: none).
    rows : (m,) general inequality rows but avoidance; a_io : (m, E) their part on ``z_O``.
    a_w : (n + m, n) ``[R^-1; G R^-1]`` (``G`` their part on u); lazy : (n + m,) its
    speed-polygon rows (on velocities only), which DAQP gets only when violated; a_lazy :
    those rows of a_w.
    avoid_row : (Y,) the avoidance row (Eq. 8d) of each binary, flat ``y`` order (step r,
    obstacle j, face i); the row of face i of obstacle j at step r is ``-(a_ji . p_r)``
    in ``w``, formed from ``pos_w (T-1, 2, n)``, the positions of steps 2..T in ``w``,
    when a QP switches that face on: avoidance rows cost no memory per obstacle.
    ``pos_o (T-1, 2)`` their indices in ``z_O``; normals : (n_obs, F, 2) the faces'.
    """

    eq: np.ndarray
    pinv: np.ndarray
    s: np.ndarray
    term: np.ndarray
    w: np.ndarray
    x_pos: np.ndarray
    u_shape: tuple
    r_inv: np.ndarray
    eye: np.ndarray
    bound_rows: np.ndarray
    bound_of: np.ndarray
    bound_coef: np.ndarray
    rows: np.ndarray
    a_io: sp.csr_matrix
    a_w: np.ndarray
    lazy: np.ndarray
    a_lazy: np.ndarray
    avoid_row: np.ndarray
    pos_w: np.ndarray
    pos_o: np.ndarray
    normals: np.ndarray

    @classmethod
    def build(cls, c: Compiled) -> "Condensed":
        """Condense ``c``; ValueError if its equality rows do not fix all but the forces."""
        is_y = np.zeros(c.n_cols, bool)
        is_y[c.y_cols.ravel()] = True
        u = c.u_cols.ravel()
        is_u = np.zeros(c.n_cols, bool)
        is_u[u] = True
        other = np.flatnonzero(~is_y & ~is_u)
        eq = np.flatnonzero((c.lo0 == c.hi0) & np.all(c.lo_map == c.hi_map, axis=1))
        a = c.a.tocsr()
        a_e = a[eq]
        if len(eq) != len(other) or a_e[:, c.y_cols.ravel()].nnz:
            raise ValueError("the equality rows do not determine the states")
        pinv = sla.lu_solve(sla.lu_factor(a_e[:, other].toarray(), check_finite=True), np.eye(len(eq)))
        s = -pinv @ a_e[:, u].toarray()
        where = np.full(c.n_cols, -1)
        where[other] = np.arange(len(other))
        term = where[c.term_cols]
        s_t = s[term]
        hess = 2.0 * s_t.T @ (c.term_w[:, None] * s_t)
        r = np.linalg.cholesky(0.5 * (hess + hess.T)).T  # H = R'R; LinAlgError if not positive definite
        r_inv = sla.solve_triangular(r, np.eye(len(u)))
        ineq = np.setdiff1d(np.arange(a.shape[0]), np.r_[eq, c.sum_rows])
        nnz = np.diff(a.indptr)
        first = np.where(nnz > 0, a.indices[np.minimum(a.indptr[:-1], max(a.nnz - 1, 0))], -1)
        single_u = (nnz == 1) & is_u[first]
        bound_rows, rows = ineq[single_u[ineq]], ineq[~single_u[ineq]]
        where_u = np.full(c.n_cols, -1)
        where_u[u] = np.arange(len(u))
        var = where_u[first[bound_rows]]
        per_var = np.bincount(var, minlength=len(u))
        bound_of = np.full((len(u), max(per_var.max(initial=0), 1)), -1)
        order = np.argsort(var, kind="stable")
        slot = np.arange(len(var)) - np.repeat(np.cumsum(per_var) - per_var, per_var)
        bound_of[var[order], slot] = order
        avoid = c.row_y[rows] >= 0
        a_r = a[rows[~avoid]]
        g = a_r[:, u].toarray() + a_r[:, other] @ s
        a_w = np.ascontiguousarray(np.vstack([r_inv, g @ r_inv]))
        lazy = np.r_[np.zeros(len(u), bool), cls._velocity_only(a_r, c)]
        avoid_row = np.zeros(c.y_cols.size, int)
        avoid_row[c.row_y[rows[avoid]]] = rows[avoid]
        pos_o = where[c.x_cols[2:, :2]]  # (T-1, 2)
        return cls(eq=eq, pinv=pinv, s=s, term=term, w=c.term_w, x_pos=where[c.x_cols], u_shape=c.u_cols.shape,
                   r_inv=r_inv, eye=np.eye(len(u)), bound_rows=bound_rows, bound_of=bound_of,
                   bound_coef=a.data[a.indptr[bound_rows]], rows=rows[~avoid], a_io=a_r[:, other].tocsr(),
                   a_w=a_w, lazy=lazy, a_lazy=np.ascontiguousarray(a_w[lazy]), avoid_row=avoid_row,
                   pos_w=np.ascontiguousarray(s[pos_o] @ r_inv), pos_o=pos_o, normals=c.normals)

    @staticmethod
    def _velocity_only(a_r: sp.csr_matrix, c: Compiled) -> np.ndarray:
        """Rows with every non-zero on a velocity column: the speed polygon."""
        is_v = np.zeros(c.n_cols, bool)
        is_v[c.x_cols[:, 2:].ravel()] = True
        per_row = np.diff(a_r.indptr)
        row = np.repeat(np.arange(a_r.shape[0]), per_row)
        off_v = np.bincount(row, weights=~is_v[a_r.indices], minlength=a_r.shape[0])
        return (per_row > 0) & (off_v == 0)

    def context(self, lo: np.ndarray, hi: np.ndarray) -> _Context:
        z0 = self.pinv @ lo[self.eq]
        t0 = z0[self.term]
        lin = self.s[self.term].T @ (2.0 * self.w * t0)
        has = self.bound_of >= 0
        idx = self.bound_rows[self.bound_of]
        coef = np.where(has, self.bound_coef[self.bound_of], 1.0)
        lo_b, hi_b = lo[idx] / coef, hi[idx] / coef
        lb = np.where(has, np.where(coef > 0, lo_b, hi_b), -np.inf).max(axis=1, initial=-np.inf)
        ub = np.where(has, np.where(coef > 0, hi_b, lo_b), np.inf).min(axis=1, initial=np.inf)
        forces = np.flatnonzero(np.isfinite(lb) | np.isfinite(ub))
        off = self.a_io @ z0
        # an avoidance row is -(a . p) <= -b, p = P_w w + p0: its offset at w = 0 is -(a . p0)
        off_face = -np.einsum("rd,nfd->rnf", z0[self.pos_o], self.normals).reshape(-1)
        ids = np.concatenate([forces, len(self.r_inv) + np.arange(len(self.rows))])
        b_lo, b_hi, a_lo, a_hi = (np.clip(v, -BIG, BIG) for v in (
            np.concatenate([lb[forces], lo[self.rows] - off]), np.concatenate([ub[forces], hi[self.rows] - off]),
            lo[self.avoid_row] - off_face, hi[self.avoid_row] - off_face))
        core, lazy = ~self.lazy[ids], self.lazy[ids]  # every speed row is a general row: lazy is a_lazy's order
        return _Context(lo.copy(), hi.copy(), z0, self.r_inv.T @ lin, float(self.w @ (t0 * t0)), ids[core],
                        self.a_w[ids[core]], b_lo[core], b_hi[core], ids[lazy], self.a_lazy, b_lo[lazy], b_hi[lazy],
                        a_lo, a_hi, bool(np.any(b_lo > b_hi)))

    def faces_on(self, y, relax, needed=None) -> np.ndarray:
        """The binaries (flat ``y`` order) whose avoidance rows a QP keeps: those with
        ``y = 0`` (``y = 1`` rows are implied by the area, tight big-M, and dropped), so
        the binaries never shift a kept row's bounds, and, given ``needed (T-1, n)`` bool,
        only for the (step, obstacle) pairs it marks: the caller knows the others' rows
        hold for every plan that matters.  Under ``relax``, none."""
        if relax or not len(self.avoid_row):
            return np.zeros(0, int)
        keep = y.reshape(-1) == 0
        if needed is not None:
            keep &= np.repeat(needed.reshape(-1), self.normals.shape[1])
        return np.flatnonzero(keep)

    def rows_for(self, y, relax, ctx, needed=None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Every row of this QP, the speed polygon's included: sorted ids (below
        ``len(a_w)``: rows of :attr:`a_w`; above: ``len(a_w) +`` a binary's avoidance row
        (:meth:`faces_on`)), their bounds (DAQP's infinity) and their matrix in ``w``."""
        on = self.faces_on(y, relax, needed)
        ids, a, rlo, rhi = ctx.rows(np.ones(len(ctx.lazy_ids), bool), len(self.a_w) + on, self.face_rows(on),
                                    ctx.a_lo[on], ctx.a_hi[on])
        return ids, rlo, rhi, a

    def face_rows(self, flat: np.ndarray) -> np.ndarray:
        """``(k, n)`` the avoidance rows in ``w`` of the binaries ``flat`` (flat ``y`` order)."""
        n_obs, f = self.normals.shape[:2]
        r, rest = np.divmod(flat, n_obs * f)
        a = self.normals.reshape(-1, 2)[rest]  # (k, 2)
        out = self.pos_w[r, 0]  # a gathered copy, then in place: half the passes of the expression
        out *= a[:, :1]
        out += a[:, 1:] * self.pos_w[r, 1]
        return np.negative(out, out=out)

    def objective(self, z: np.ndarray) -> float:
        t = z[self.term]
        return float(self.w @ (t * t))

    def verified(self, f, a_w, w, lam, rlo, rhi, ctx) -> bool:
        """The plan meets the kept rows within FEAS_TOL and its objective is within
        GAP_TOL of the Lagrangian dual value of DAQP's multipliers ``lam`` (upper rows
        ``lam > 0``, lower rows ``lam < 0``): ``q = c0 - 1/2 |lin_w + A_w' lam|^2 - beta``
        bounds the optimum from below for any multipliers of the right signs."""
        au = a_w @ w
        if np.any(au > rhi + FEAS_TOL) or np.any(au < rlo - FEAS_TOL):
            return False
        up, down = np.maximum(lam, 0.0), np.minimum(lam, 0.0)
        if np.any(np.abs(rhi[up > 0]) >= BIG) or np.any(np.abs(rlo[down < 0]) >= BIG):
            return False
        r = ctx.lin_w + a_w.T @ lam
        q = ctx.c0 - 0.5 * float(r @ r) - float(up @ rhi) - float(down @ rlo)
        return f - q <= GAP_TOL * max(f, 1.0)


class ClarabelQP:
    """The fixed-face QP in its sparse form by Clarabel (interior point), HiGHS's QP
    behind it: the method before DAQP (commit d6ed022), now the fallback and the reference.

    On the paper mission HiGHS's active-set QP needed about 1000 iterations and 66-100 ms
    per solve, and stops with "solve error" on some instances; Clarabel takes 4-5 ms.
    """

    def __init__(self, c: Compiled):
        self.c = c
        n = c.n_cols
        is_y = np.zeros(n, bool)
        is_y[c.y_cols.ravel()] = True
        self.keep = np.flatnonzero(~is_y)
        where = np.full(n, -1)
        where[self.keep] = np.arange(len(self.keep))
        self.a_z = c.a[:, self.keep].tocsr()
        self.a_y = c.a[:, c.y_cols.ravel()].tocsc()
        self.term = where[c.term_cols]
        self.x_idx, self.u_idx = where[c.x_cols], where[c.u_cols]
        w = np.zeros(len(self.keep))
        w[self.term] = 2.0 * c.term_w
        self.p = sp.diags(w).tocsc()
        self.q = np.zeros(len(self.keep))
        self.settings = clarabel.DefaultSettings()
        self.settings.verbose = False
        self.avoid = c.row_y >= 0
        self._highs = None

    def solve(self, lo: np.ndarray, hi: np.ndarray, y: np.ndarray, relax: bool = False,
              needed: np.ndarray | None = None) -> QpSolution | None:
        """As :meth:`FixedFaceQP.solve`."""
        yv = np.ones(self.a_y.shape[1]) if relax else y.reshape(-1).astype(float)
        shift = self.a_y @ yv
        lo, hi = lo - shift, hi - shift
        drop = np.zeros(len(lo), bool)
        drop[self.avoid] = relax | (yv[self.c.row_y[self.avoid]] == 1)
        if needed is not None:
            drop[self.avoid] |= ~np.repeat(needed.reshape(-1), self.c.normals.shape[1])[self.c.row_y[self.avoid]]
        drop[self.c.sum_rows] = True
        eq = (lo == hi) & ~drop
        up = np.isfinite(hi) & ~eq & ~drop
        down = np.isfinite(lo) & ~eq & ~drop
        a = sp.vstack([self.a_z[eq], self.a_z[up], -self.a_z[down]]).tocsc()
        b = np.r_[hi[eq], hi[up], -lo[down]]
        cones = [clarabel.ZeroConeT(int(eq.sum())), clarabel.NonnegativeConeT(int(up.sum() + down.sum()))]
        sol = clarabel.DefaultSolver(self.p, self.q, a, b, cones, self.settings).solve()
        status = str(sol.status)
        if status in _SOLVED:
            return self._pack(np.asarray(sol.x), y if not relax else np.ones_like(y))
        if status in _INFEASIBLE:
            return None
        return self._solve_highs(lo + shift, hi + shift, yv, relax, y)

    def _pack(self, z: np.ndarray, y: np.ndarray) -> QpSolution:
        s = z[self.term]
        return QpSolution(float(self.c.term_w @ (s * s)), z[self.x_idx], z[self.u_idx], s, np.array(y, float))

    def _solve_highs(self, lo, hi, yv, relax, y) -> QpSolution | None:
        """Fallback: the same QP in HiGHS (binaries fixed by bounds)."""
        c = self.c
        if self._highs is None:
            self._highs = new_highs()
            hess = np.zeros(c.n_cols)
            hess[c.term_cols] = 2.0 * c.term_w
            pass_model(self._highs, c.a, np.zeros(c.n_cols), c.col_lo, c.col_hi, lo, hi,
                       np.zeros(c.n_cols), hess_diag=hess)
        h = self._highs
        h.changeRowsBounds(len(lo), np.arange(len(lo), dtype=np.int32), lo, hi)
        if relax:
            rows = c.sum_rows
            h.changeRowsBounds(len(rows), rows, np.full(len(rows), -highspy.kHighsInf), np.full(len(rows), 4.0))
        cols = c.y_cols.ravel()
        h.changeColsBounds(len(cols), cols, yv, yv)
        h.run()
        status = h.getModelStatus()
        if status == highspy.HighsModelStatus.kInfeasible:
            return None
        if status != highspy.HighsModelStatus.kOptimal:
            raise SolverError(f"fixed-face QP failed in Clarabel and HiGHS ({h.modelStatusToString(status)})")
        z = np.asarray(h.getSolution().col_value)
        s = z[c.term_cols]
        return QpSolution(float(c.term_w @ (s * s)), z[c.x_cols], z[c.u_cols], s, np.array(y, float))
