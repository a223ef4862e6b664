"""P1 compiled once by cvxpy into matrices HiGHS and Clarabel can take.

cvxpy refuses to hand a mixed-integer QP to HiGHS (HiGHS has no MIQP), but its HiGHS QP
interface compiles one perfectly well once told binaries are allowed.  The compiled
program is ``row_lo <= a z <= row_hi``, ``col_lo <= z <= col_hi``, objective
``sum_k w_k z[term_k]^2``.  Only right-hand sides depend on the parameters, affinely; the
map is read off cvxpy's parametric program once, so a re-plan costs a 6-column matvec.
"""

from __future__ import annotations

from dataclasses import dataclass

import cvxpy as cp
import highspy
import numpy as np
import scipy.sparse as sp
from cvxpy.reductions.solvers.qp_solvers.highs_qpif import HIGHS as _HighsQp

from .model import P1

INF = highspy.kHighsInf


class _MiqpData(_HighsQp):
    """cvxpy's HiGHS QP interface, allowed to see binaries: only used to compile P1."""

    MIP_CAPABLE = True

    def name(self):
        return "UAVSIM_MIQP_DATA"


@dataclass(frozen=True, eq=False)
class Compiled:
    """P1 compiled by cvxpy to ``row_lo <= a z <= row_hi``, ``col_lo <= z <= col_hi``.

    Right-hand sides are affine in the parameters ``theta = [x0 (4), goal (2)]``:
    ``row_lo = lo0 + lo_map theta`` (likewise hi), found once by evaluating cvxpy's
    parametric program; the matrix does not depend on theta (checked).
    """

    a: sp.csr_matrix
    lo0: np.ndarray
    hi0: np.ndarray
    lo_map: np.ndarray
    hi_map: np.ndarray
    param_rows: np.ndarray  # rows whose bounds depend on theta
    col_lo: np.ndarray
    col_hi: np.ndarray
    y_cols: np.ndarray  # (T-1, 4n) column of each binary
    term_cols: np.ndarray  # (K,) columns of e and d
    term_w: np.ndarray  # (K,) objective weights w_k
    n_terms_e: int  # the first n_terms_e terms are e (metres), the rest d (kN)
    x_cols: np.ndarray  # (T+1, 4)
    u_cols: np.ndarray  # (T, 2)
    sum_rows: np.ndarray  # rows of Eq. (8e)
    row_y: np.ndarray  # (rows,) for a big-M row of Eq. (8d), its binary (flat index into y_cols); else -1

    @property
    def n_cols(self) -> int:
        return self.a.shape[1]

    def rows(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.lo0 + self.lo_map @ theta, self.hi0 + self.hi_map @ theta


def _cols(pp, var) -> np.ndarray:
    start = pp.var_id_to_col[var.id]
    # cvxpy stacks variables column-major (Fortran order)
    return (start + np.arange(var.size)).reshape(var.shape, order="F")


def compile_p1(p1: P1) -> Compiled:
    """Compile the cvxpy model once; see :class:`Compiled`."""
    p1.x0.value, p1.goal.value = np.zeros(4), np.zeros(2)
    data, _, _ = p1.problem.get_problem_data(solver=_MiqpData(), canon_backend=cp.SCIPY_CANON_BACKEND)
    pp = data[cp.settings.PARAM_PROB]
    n_eq = data["n_eq"]

    def evaluate(theta):
        p1.x0.value, p1.goal.value = theta[:4], theta[4:]
        _, _, _, af, bg = pp.apply_parameters(quad_obj=True)
        sign = np.r_[np.ones(n_eq), -np.ones(af.shape[0] - n_eq)]
        a = sp.diags(sign) @ af  # equalities a z = -bg; inequalities -af z <= bg
        lo = np.r_[-bg[:n_eq], np.full(af.shape[0] - n_eq, -INF)]
        hi = np.r_[-bg[:n_eq], bg[n_eq:]]
        return sp.csr_matrix(a), lo, hi

    a, lo0, hi0 = evaluate(np.zeros(6))
    lo_map, hi_map = np.zeros((len(lo0), 6)), np.zeros((len(lo0), 6))
    for k in range(6):
        a_k, lo_k, hi_k = evaluate(np.eye(6)[k])
        if (a_k != a).nnz:
            raise RuntimeError("P1 compiled with a parameter-dependent matrix; expected RHS only")
        with np.errstate(invalid="ignore"):
            lo_map[:, k] = np.where(np.isfinite(lo0), lo_k - lo0, 0.0)
            hi_map[:, k] = np.where(np.isfinite(hi0), hi_k - hi0, 0.0)

    n = a.shape[1]
    col_lo = np.full(n, -INF) if data["lower_bounds"] is None else np.asarray(data["lower_bounds"], float)
    col_hi = np.full(n, INF) if data["upper_bounds"] is None else np.asarray(data["upper_bounds"], float)
    y_cols = _cols(pp, p1.y)
    col_lo[y_cols], col_hi[y_cols] = 0.0, 1.0
    diag = data["P"].diagonal()
    if sp.triu(data["P"], 1).nnz or sp.tril(data["P"], -1).nnz:
        raise RuntimeError("P1 objective is expected to be a diagonal sum of squares")
    e_cols, d_cols = _cols(pp, p1.e), _cols(pp, p1.d).reshape(-1)
    term_cols = np.r_[e_cols, d_cols].astype(np.int32)
    is_y = np.zeros(n, bool)
    is_y[y_cols] = True
    nz_rows = np.repeat(np.arange(a.shape[0]), np.diff(a.indptr))
    rows_all_y = np.bincount(nz_rows, weights=~is_y[a.indices], minlength=a.shape[0]) == 0
    sum_rows = np.flatnonzero(rows_all_y & np.isinf(lo0))
    flat = np.full(n, -1)
    flat[y_cols.ravel()] = np.arange(y_cols.size)
    row_y = np.full(a.shape[0], -1)
    mixed = is_y[a.indices] & ~rows_all_y[nz_rows]
    row_y[nz_rows[mixed]] = flat[a.indices[mixed]]
    # Eq. (8d) rows must read -(a_i . p) - M y <= -b_i, so that shrinking b_i raises row_hi
    if np.any(a.data[mixed] >= 0) or np.any(np.isfinite(lo0[row_y >= 0])):
        raise RuntimeError("unexpected orientation of the compiled avoidance rows")
    return Compiled(
        a=a, lo0=lo0, hi0=hi0, lo_map=lo_map, hi_map=hi_map,
        param_rows=np.flatnonzero(np.any(lo_map != 0, axis=1) | np.any(hi_map != 0, axis=1)).astype(np.int32),
        col_lo=col_lo, col_hi=col_hi, y_cols=y_cols.astype(np.int32), term_cols=term_cols,
        term_w=diag[term_cols] / 2.0, n_terms_e=len(e_cols), x_cols=_cols(pp, p1.x),
        u_cols=_cols(pp, p1.u), sum_rows=sum_rows.astype(np.int32), row_y=row_y,
    )


def new_highs(**options) -> highspy.Highs:
    """A silent single-threaded HiGHS instance; unknown options are an error."""
    h = highspy.Highs()
    h.setOptionValue("output_flag", False)
    h.setOptionValue("threads", 1)
    for key, value in options.items():
        if h.setOptionValue(key, value) != highspy.HighsStatus.kOk:
            raise RuntimeError(f"HiGHS rejected option {key}={value!r}")
    return h


def pass_model(h: highspy.Highs, a: sp.csr_matrix, cost, col_lo, col_hi, row_lo, row_hi, integrality,
               hess_diag=None) -> None:
    """Load ``row_lo <= a z <= row_hi`` (CSR), bounds, costs, integrality and an optional
    diagonal Hessian (objective ``1/2 z' diag(h) z + cost' z``) into ``h``."""
    i32 = np.int32
    args = (a.indptr.astype(i32), a.indices.astype(i32), a.data.astype(float))
    if hess_diag is None:
        h.passModel(a.shape[1], a.shape[0], a.nnz, 2, 1, 0.0, cost, col_lo, col_hi, row_lo, row_hi,
                    *args, integrality.astype(i32))
    else:
        q = sp.diags(hess_diag).tocsc()
        h.passModel(a.shape[1], a.shape[0], a.nnz, q.nnz, 2, 1, 1, 0.0, cost, col_lo, col_hi, row_lo,
                    row_hi, *args, q.indptr.astype(i32), q.indices.astype(i32), q.data.astype(float),
                    integrality.astype(i32))
