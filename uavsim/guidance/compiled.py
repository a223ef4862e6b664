"""P1 as matrices HiGHS and Clarabel can take: ``row_lo <= a z <= row_hi``,
``col_lo <= z <= col_hi``, objective ``sum_k w_k z[term_k]^2``.

Two routes to the same program:

* :func:`assemble_p1` writes the sparse rows of Eq. (8b)-(8f) directly (about 1 ms per
  horizon length), which is what the solver uses: a shrinking horizon needs a program
  for every length 2..T, and compiling each through cvxpy cost ~60 ms, 3 s in all.
* :func:`compile_p1` reads the same program off the cvxpy model of :mod:`.model` (the
  readable statement of P1, also handed to SCIP); the tests check that both give the
  same optima.  cvxpy refuses to hand a mixed-integer QP to HiGHS (HiGHS has no MIQP),
  but its HiGHS QP interface compiles one once told binaries are allowed.

Only right-hand sides depend on the parameters ``theta = [x0 (4), goal (2), applied (2)]``
(``applied``: the force applied the step before, kN, read only with the link term of
:attr:`.model.GuidanceConfig.link`), affinely, so a re-plan costs an 8-column matvec.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import highspy
import numpy as np
import scipy.sparse as sp

from .model import KN, P1, Geometry

INF = highspy.kHighsInf
N_THETA = 8  # parameters: x0 (4), goal (2), the force applied the step before (2)


@cache
def _miqp_data() -> type:
    """cvxpy's HiGHS QP interface, allowed to see binaries: only used to compile P1
    (made on first use, so that the solver's path does not import cvxpy)."""
    from cvxpy.reductions.solvers.qp_solvers.highs_qpif import HIGHS

    class _MiqpData(HIGHS):
        MIP_CAPABLE = True

        def name(self):
            return "UAVSIM_MIQP_DATA"

    return _MiqpData


@dataclass(frozen=True, eq=False)
class Compiled:
    """P1 compiled by cvxpy to ``row_lo <= a z <= row_hi``, ``col_lo <= z <= col_hi``.

    Right-hand sides are affine in the parameters ``theta = [x0 (4), goal (2), applied (2)]``:
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
    term_cols: np.ndarray  # (K,) columns of e, d and (with the link term) u_0 - applied
    term_w: np.ndarray  # (K,) objective weights w_k
    n_terms_e: int  # the first n_terms_e terms are e (metres), the rest d (kN)
    x_cols: np.ndarray  # (T+1, 4)
    u_cols: np.ndarray  # (T, 2)
    sum_rows: np.ndarray  # rows of Eq. (8e)
    row_y: np.ndarray  # (rows,) for a big-M row of Eq. (8d), its binary (flat index into y_cols); else -1
    normals: np.ndarray  # (n, F, 2) the faces' outward unit normals: y_cols is (T-1, n F), face i of j at F j + i
    terminal_rows: np.ndarray | None = None  # (2,) the area rows of p_T (x, y): a hard terminal tightens them

    @property
    def n_cols(self) -> int:
        return self.a.shape[1]

    def rows(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Row bounds at ``theta``: ``[x0, goal]`` or ``[x0, goal, applied]`` (applied zero if left out)."""
        theta = np.r_[theta, np.zeros(N_THETA - len(theta))]
        return self.lo0 + self.lo_map @ theta, self.hi0 + self.hi_map @ theta


def _cols(pp, var) -> np.ndarray:
    start = pp.var_id_to_col[var.id]
    # cvxpy stacks variables column-major (Fortran order)
    return (start + np.arange(var.size)).reshape(var.shape, order="F")


def compile_p1(p1: P1) -> Compiled:
    """Compile the cvxpy model once; see :class:`Compiled`."""
    import cvxpy as cp

    p1.x0.value, p1.goal.value = np.zeros(4), np.zeros(2)
    if p1.applied is not None:
        p1.applied.value = np.zeros(2)
    data, _, _ = p1.problem.get_problem_data(solver=_miqp_data()(), canon_backend=cp.SCIPY_CANON_BACKEND)
    pp = data[cp.settings.PARAM_PROB]
    n_eq = data["n_eq"]

    def evaluate(theta):
        p1.x0.value, p1.goal.value = theta[:4], theta[4:6]
        if p1.applied is not None:
            p1.applied.value = theta[6:]
        _, _, _, af, bg = pp.apply_parameters(quad_obj=True)
        sign = np.r_[np.ones(n_eq), -np.ones(af.shape[0] - n_eq)]
        a = sp.diags(sign) @ af  # equalities a z = -bg; inequalities -af z <= bg
        lo = np.r_[-bg[:n_eq], np.full(af.shape[0] - n_eq, -INF)]
        hi = np.r_[-bg[:n_eq], bg[n_eq:]]
        return sp.csr_matrix(a), lo, hi

    a, lo0, hi0 = evaluate(np.zeros(N_THETA))
    lo_map, hi_map = np.zeros((len(lo0), N_THETA)), np.zeros((len(lo0), N_THETA))
    for k in range(N_THETA if p1.applied is not None else 6):
        a_k, lo_k, hi_k = evaluate(np.eye(N_THETA)[k])
        if (a_k != a).nnz:
            raise RuntimeError("P1 compiled with a parameter-dependent matrix; expected RHS only")
        with np.errstate(invalid="ignore"):
            lo_map[:, k] = np.where(np.isfinite(lo0), lo_k - lo0, 0.0)
            hi_map[:, k] = np.where(np.isfinite(hi0), hi_k - hi0, 0.0)

    n = a.shape[1]
    col_lo = np.full(n, -INF) if data["lower_bounds"] is None else np.asarray(data["lower_bounds"], float)
    col_hi = np.full(n, INF) if data["upper_bounds"] is None else np.asarray(data["upper_bounds"], float)
    y_cols = _cols(pp, p1.y) if p1.y.id in pp.var_id_to_col else np.zeros((p1.horizon - 1, 0), int)
    col_lo[y_cols], col_hi[y_cols] = 0.0, 1.0
    diag = data["P"].diagonal()
    if sp.triu(data["P"], 1).nnz or sp.tril(data["P"], -1).nnz:
        raise RuntimeError("P1 objective is expected to be a diagonal sum of squares")
    e_cols, d_cols = _cols(pp, p1.e), _cols(pp, p1.d).reshape(-1)
    link_cols = _cols(pp, p1.link) if p1.link is not None else np.zeros(0, int)
    term_cols = np.r_[e_cols, d_cols, link_cols].astype(np.int32)
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
        u_cols=_cols(pp, p1.u), sum_rows=sum_rows.astype(np.int32), row_y=row_y, normals=p1.geom.face_normals,
    )


def assemble_p1(geom: Geometry, dt: float, friction: float, mass: float, horizon: int, rho: float,
                force_max: float, link: bool = False) -> Compiled:
    """The program of :func:`compile_p1`, written row by row (see module docstring).

    Columns: ``x (T+1, 4)`` row-major, ``u (T, 2)``, ``e (2,)``, ``d (T-1, 2)`` stored
    column-major as cvxpy does (all d_x, then all d_y), ``y (T-1, n, F)``, and with
    ``link`` ``k (2,)`` = ``u_0 - applied`` (weighted rho, the last terms).  Rows, in
    order: start (8c), position and velocity dynamics (8b), terminal error, control
    increments, force bounds, speed polygon, area (8f), avoidance (8d), one face per
    obstacle and step (8e), and the link's definition.  ``rho`` and ``force_max`` in the
    model's units (kN).
    """
    t, (n, f) = horizon, geom.face_offsets.shape
    x_cols = np.arange((t + 1) * 4).reshape(t + 1, 4)
    u_cols = x_cols.size + np.arange(t * 2).reshape(t, 2)
    e_cols = u_cols.size + x_cols.size + np.arange(2)
    d_cols = e_cols[-1] + 1 + np.arange((t - 1) * 2).reshape(2, t - 1).T  # column-major, as cvxpy
    y_cols = d_cols.size + e_cols[-1] + 1 + np.arange((t - 1) * n * f).reshape(t - 1, n * f)
    k_cols = y_cols.size + d_cols.size + e_cols[-1] + 1 + np.arange(2 if link else 0)
    n_cols = k_cols[-1] + 1 if link else y_cols.size + d_cols.size + e_cols[-1] + 1
    rows = _Rows()
    k = np.arange(t)
    rows.eq(x_cols[0].reshape(4, 1), [1.0], param=np.eye(4, N_THETA))  # x_0 = x0
    for i in range(2):  # p_{k+1} - p_k - dt v_k = 0 and v_{k+1} - (1 - eps) v_k - gain u_k = 0
        rows.eq(np.c_[x_cols[k + 1, i], x_cols[k, i], x_cols[k, 2 + i]], [1.0, -1.0, -dt])
        rows.eq(np.c_[x_cols[k + 1, 2 + i], x_cols[k, 2 + i], u_cols[k, i]], [1.0, -(1.0 - friction), -dt * KN / mass])
    rows.eq(np.c_[e_cols, x_cols[t, :2]], [1.0, -1.0], param=-np.eye(2, N_THETA, 4))  # e = p_T - goal
    kd = np.arange(t - 1)
    for i in range(2):
        rows.eq(np.c_[d_cols[kd, i], u_cols[kd + 1, i], u_cols[kd, i]], [1.0, -1.0, 1.0])
    rows.box(u_cols.reshape(-1, 1), [1.0], -force_max, force_max)
    v = x_cols[1:, 2:]  # (T, 2) velocities after each control
    dirs = geom.speed_dirs
    rows.box(np.repeat(v, len(dirs), axis=0), np.tile(dirs, (t, 1)), -INF, geom.speed_bound)
    terminal_rows = []
    for i in range(2):
        rows.box(x_cols[2:, i:i + 1], [1.0], geom.area_lo[i], geom.area_hi[i])
        terminal_rows.append(rows.count - 1)
    row_y = np.full(rows.count, -1)
    if n:
        # -(a_i . p) - M_i y <= -b_i for face i of obstacle j at step r (tau = r + 2)
        r, j, i = np.unravel_index(np.arange((t - 1) * n * f), (t - 1, n, f))
        a = geom.face_normals[j, i]
        cols = np.c_[x_cols[r + 2, 0], x_cols[r + 2, 1], y_cols.reshape(-1)]
        coef = np.c_[-a, -geom.big_m[j, i]]
        first = rows.count
        rows.box(cols, coef, -INF, -geom.face_offsets[j, i])
        row_y = np.r_[row_y, np.arange(len(r))]
        sums = first + len(r)
        rows.box(y_cols.reshape(-1, f), np.ones(f), -INF, f - 1.0)  # Eq. (8e) without the z-faces
        row_y = np.r_[row_y, np.full(rows.count - len(row_y), -1)]
        sum_rows = np.arange(sums, rows.count)
    else:
        sum_rows = np.zeros(0, int)
    if link:  # k - u_0 = -applied
        rows.eq(np.c_[k_cols, u_cols[0]], [1.0, -1.0], param=-np.eye(2, N_THETA, 6))
        row_y = np.r_[row_y, np.full(2, -1)]
    a, lo0, hi0, lo_map, hi_map = rows.build(n_cols)
    col_lo, col_hi = np.full(n_cols, -INF), np.full(n_cols, INF)
    col_lo[y_cols], col_hi[y_cols] = 0.0, 1.0
    term_cols = np.r_[e_cols, d_cols.T.reshape(-1), k_cols].astype(np.int32)
    return Compiled(
        a=a, lo0=lo0, hi0=hi0, lo_map=lo_map, hi_map=hi_map,
        param_rows=np.flatnonzero(np.any(lo_map != 0, axis=1)).astype(np.int32),
        col_lo=col_lo, col_hi=col_hi, y_cols=y_cols.astype(np.int32), term_cols=term_cols,
        term_w=np.r_[1.0, 1.0, np.full(2 * (t - 1) + len(k_cols), rho)], n_terms_e=2, x_cols=x_cols, u_cols=u_cols,
        sum_rows=sum_rows.astype(np.int32), row_y=row_y, normals=geom.face_normals,
        terminal_rows=np.array(terminal_rows),
    )


class _Rows:
    """Sparse rows collected in blocks: ``cols (r, k)`` with coefficients ``(k,)`` or
    ``(r, k)``; bounds per block; ``param (rows_per_block..., N_THETA)`` the RHS map."""

    def __init__(self):
        self.blocks, self.count = [], 0

    def box(self, cols, coef, lo, hi, param=None):
        cols = np.atleast_2d(np.asarray(cols))
        coef = np.broadcast_to(np.asarray(coef, float), cols.shape)
        r = cols.shape[0]
        self.blocks.append((cols, coef, np.broadcast_to(lo, (r,)), np.broadcast_to(hi, (r,)),
                            np.zeros((r, N_THETA)) if param is None else np.asarray(param, float)))
        self.count += r

    def eq(self, cols, coef, param=None):
        cols = np.atleast_2d(np.asarray(cols))
        self.box(cols, coef, 0.0, 0.0, param)

    def build(self, n_cols):
        cols = np.concatenate([b[0].reshape(-1) for b in self.blocks])
        data = np.concatenate([b[1].reshape(-1) for b in self.blocks])
        rows = np.concatenate([np.repeat(np.arange(b[0].shape[0]), b[0].shape[1]) for b in self.blocks])
        starts = np.cumsum([0] + [b[0].shape[0] for b in self.blocks[:-1]])
        rows = rows + np.repeat(starts, [b[0].size for b in self.blocks])
        nz = data != 0  # an axis-aligned face has one position coefficient, not two
        a = sp.csr_matrix((data[nz], (rows[nz], cols[nz])), shape=(self.count, n_cols))
        a.sum_duplicates()
        lo = np.concatenate([b[2] for b in self.blocks]).astype(float)
        hi = np.concatenate([b[3] for b in self.blocks]).astype(float)
        param = np.concatenate([b[4] for b in self.blocks])
        eq = lo == hi
        return a, lo, hi, np.where(eq[:, None], param, 0.0), np.where(eq[:, None], param, 0.0)


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
