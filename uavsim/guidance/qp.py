"""The convex QP of P1 with the face choice fixed: the outer approximation's upper bound.

With every binary fixed, Eq. (8d) keeps only the active faces (``y = 1`` rows are
implied by the area bounds, because big-M is tight to the area) and P1 is a convex QP.
It is solved by Clarabel (interior point), which ships with cvxpy: on the paper mission
HiGHS's active-set QP needed about 1000 iterations and 66-100 ms per solve, and stops
with "solve error" on some instances; Clarabel takes 4-5 ms.  HiGHS's QP stays as the
fallback, so a failure of one solver is not a failure of the plan.
"""

from __future__ import annotations

from dataclasses import dataclass

import clarabel
import highspy
import numpy as np
import scipy.sparse as sp

from .compiled import Compiled, new_highs, pass_model

_SOLVED = {"Solved", "AlmostSolved"}
_INFEASIBLE = {"PrimalInfeasible", "AlmostPrimalInfeasible"}


@dataclass(frozen=True, eq=False)
class QpSolution:
    """A feasible plan for one face choice (model units).

    f : objective Eq. (7) in m^2; x : (T+1, 4) states; u : (T, 2) kN;
    s : (K,) squared-term values [e, d]; y : (T-1, n, 4) the face choice.
    """

    f: float
    x: np.ndarray
    u: np.ndarray
    s: np.ndarray
    y: np.ndarray


class FixedFaceQP:
    """Solves P1 for a fixed face choice; the binaries are eliminated into the RHS."""

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

    def solve(self, lo: np.ndarray, hi: np.ndarray, y: np.ndarray, relax: bool = False) -> QpSolution | None:
        """Optimal plan for face choice ``y (T-1, n, 4)`` and row bounds ``lo, hi`` (the
        current parameters).  ``relax`` drops Eq. (8d)-(8e) entirely: the obstacle-free
        QP, a relaxation of P1.  Returns None when the QP is infeasible."""
        yv = np.ones(self.a_y.shape[1]) if relax else y.reshape(-1).astype(float)
        shift = self.a_y @ yv
        lo, hi = lo - shift, hi - shift
        drop = np.zeros(len(lo), bool)
        drop[self.avoid] = relax | (yv[self.c.row_y[self.avoid]] == 1)
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
            raise RuntimeError(f"fixed-face QP failed in Clarabel and HiGHS ({h.modelStatusToString(status)})")
        z = np.asarray(h.getSolution().col_value)
        s = z[c.term_cols]
        return QpSolution(float(c.term_w @ (s * s)), z[c.x_cols], z[c.u_cols], s, np.array(y, float))
