"""Batch maximum-likelihood bearings-only TMA: the cost, its derivatives, Gauss-Newton.

For a target whose position is linear in its parameters ``theta (n,)``,
``p(t_k) = Phi_k theta`` (``Phi (K, 2, n)``; constant velocity: ``n = 4``, constant
acceleration: ``n = 6``, :func:`polynomial_basis`), seen from observer positions
``o_k`` with bearings ``z_k = h_k(theta) + N(0, sigma_k^2)``:

* bearing (internal convention, as [Oliva2021, Eq. (3)] and [Huang2021, Eq. (5)]):
  ``h_k = atan2(dy, dx)``, from +x anticlockwise, ``d_k = Phi_k theta - o_k``.  Paper
  modules convert at their edge ([Oh2021], from north clockwise: ``h = pi/2 - theta_north``,
  :mod:`.nrpso`).
* residual, wrapped to (-pi, pi]: ``e_k = z_k - h_k = atan2(s_k, c_k)`` with
  ``u_k = (cos z_k, sin z_k)``, ``c_k = u_k . d_k``, ``s_k = u_k,y d_x - u_k,x d_y``.
  ``s``, ``c`` and ``d`` are linear in ``theta``: one matrix product per run gives them
  (:class:`BearingData` holds the matrices).
* negative log-likelihood ``lam = 1/2 sum_k e_k^2 / sigma_k^2`` ([Oliva2021, Eq. (10)];
  [Oh2021]'s cost Eq. 5 is ``J = 2 lam``).
* gradient ``M = d lam / d theta = -sum_k g_k e_k / sigma_k^2`` with
  ``g_k = dh_k / dtheta = Phi_k^T rho_k``, ``rho_k = (-dy, dx) / r_k^2`` ([Oh2021, Eq. (7)],
  [Oliva2021, Appendix A]).
* Fisher information ``F = sum_k g_k g_k^T / sigma_k^2 = sum_k Phi_k^T rho_k rho_k^T Phi_k
  / sigma_k^2``: the Gauss-Newton matrix of ``lam`` and [Oliva2021, Eq. (16)]; at the truth its
  inverse is the CRLB.  Three products ``rho_x^2, rho_x rho_y, rho_y^2`` per scan times
  fixed matrices of ``Phi``; for a polynomial track most of those matrices' entries are
  zero and are skipped (10 multiply-adds per scan for n = 4).
* full Hessian ``d2 lam = F - sum_k e_k Phi_k^T d2h_k Phi_k / sigma_k^2`` with
  ``d2h = [[2 dx dy, dy^2 - dx^2], [dy^2 - dx^2, -2 dx dy]] / r^4``.

Shapes: R runs (each its own bearings and observer track), parameters ``theta (R, P, n)``
for P candidates or particles per run; results ``(R, P)``, ``(R, P, n)``, ``(R, P, n, n)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .angles import atan2_into


def polynomial_basis(times, order: int = 1, t_ref: float | None = None) -> np.ndarray:
    """``Phi (K, 2, 2 (order + 1))`` of a polynomial track in ``tau = t - t_ref``:
    ``p = sum_m theta_m tau^m / m!`` with ``theta_m = (x_m, y_m)``, so order 1 (constant
    velocity) has ``theta = [px, py, vx, vy]`` ([Oh2021, Eq. (1)-(2)]) and order 2 (constant
    acceleration) ``[x0, y0, vx, vy, ax, ay]`` ([Oliva2021, Eq. (11)-(12)]).  ``t_ref`` defaults to
    ``times[0]``: theta is the state at the first scan."""
    t = np.asarray(times, float)
    if t.ndim != 1 or len(t) == 0 or not np.isfinite(t).all():
        raise ValueError("times must be a non-empty 1-D array of finite values")
    tau = t - (t[0] if t_ref is None else t_ref)
    coef = np.stack([tau**m / np.prod(np.arange(1, m + 1)) for m in range(order + 1)], -1)  # (K, m)
    return np.einsum("km,ij->kimj", coef, np.eye(2)).reshape(len(t), 2, 2 * (order + 1))


@dataclass(frozen=True)
class BearingData:
    """R batches of K bearings as matrices (module docstring).

    ``design (R, 4, n+1, K)``: ``[theta, 1] @ design[:, i]`` is ``s, c, dx, dy`` for
    i = 0..3.  ``grad_basis (R, 2, K, n)``: ``Phi_x / sigma^2`` and ``-Phi_y / sigma^2``.
    ``fisher_basis``: the upper triangles of ``Phi_x Phi_x^T``,
    ``-(Phi_x Phi_y^T + Phi_y Phi_x^T)`` and ``Phi_y Phi_y^T`` over ``sigma^2``, each an
    ``(R, K, m)`` array cut to its ``m`` entries that are not zero, ``fisher_cols``
    (indices into the upper triangle; this takes the Fisher matrix's cost from 30 to 10
    multiply-adds per scan for a constant-velocity track).
    ``weights (R, K) = 1 / sigma^2``.  One dtype for all (float32 halves the time of a
    swarm's evaluations; :mod:`.nrpso` says where it uses it and what it costs)."""

    design: np.ndarray
    grad_basis: np.ndarray
    fisher_basis: tuple
    fisher_cols: tuple
    weights: np.ndarray
    n: int

    @property
    def runs(self) -> int:
        return self.design.shape[0]

    @property
    def scans(self) -> int:
        return self.weights.shape[1]

    @property
    def dtype(self) -> np.dtype:
        return self.design.dtype

    def _map(self, fn) -> BearingData:
        return BearingData(fn(self.design, -1), fn(self.grad_basis, 2), tuple(fn(b, 1) for b in self.fisher_basis),
                           self.fisher_cols, fn(self.weights, 1), self.n)

    def astype(self, dtype) -> BearingData:
        return self._map(lambda a, _: np.ascontiguousarray(a, dtype))

    def take(self, runs) -> BearingData:
        """The data of some runs (an index array or slice)."""
        return self._map(lambda a, _: a[runs])

    def subset(self, scans) -> BearingData:
        """The data of some scans (an index array or slice) of every run."""
        def cut(a, axis):  # scans are on this axis
            return np.ascontiguousarray(a[(slice(None),) * (axis % a.ndim) + (scans,)])

        return self._map(cut)


def _nonzero_columns(basis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``basis (R, K, m)`` cut to its columns that are not zero everywhere, and their indices."""
    cols = np.flatnonzero(np.any(basis != 0, axis=(0, 1)))
    return np.ascontiguousarray(basis[..., cols]), cols


def prepare(phi, observer, bearings, sigma, dtype=np.float64) -> BearingData:
    """:class:`BearingData` from ``phi (K, 2, n)``, observer positions ``(K, 2)`` or
    ``(R, K, 2)``, measured bearings ``(K,)`` or ``(R, K)`` (rad, from +x anticlockwise) and
    noise std ``sigma`` (rad; scalar, ``(R, 1)`` or ``(R, K)``).  Raises ValueError on
    shapes that do not fit or on non-finite or non-positive values."""
    phi = np.asarray(phi, float)
    z = np.atleast_2d(np.asarray(bearings, float))
    r, k = z.shape
    if phi.ndim != 3 or phi.shape[:2] != (k, 2):
        raise ValueError(f"phi must be (K, 2, n) with K = {k} bearings; got {phi.shape}")
    obs = np.asarray(observer, float)
    if obs.shape not in ((k, 2), (r, k, 2)):
        raise ValueError(f"observer positions must be ({k}, 2) or ({r}, {k}, 2); got {obs.shape}")
    sig = np.asarray(sigma, float)
    for name, a in (("phi", phi), ("observer", obs), ("bearings", z), ("sigma", sig)):
        if not np.isfinite(a).all():
            raise ValueError(f"{name} has non-finite values")
    if (sig <= 0).any():
        raise ValueError("sigma must be positive")
    try:
        w = np.ascontiguousarray(np.broadcast_to(1.0 / sig**2, (r, k)))
    except ValueError:
        raise ValueError(f"sigma must broadcast to ({r}, {k}); got {sig.shape}") from None
    n = phi.shape[2]
    obs = np.broadcast_to(obs, (r, k, 2))
    ux, uy = np.cos(z)[..., None], np.sin(z)[..., None]  # (R, K, 1)
    px, py = np.broadcast_to(phi[:, 0], (r, k, n)), np.broadcast_to(phi[:, 1], (r, k, n))
    rows = np.stack([uy * px - ux * py, ux * px + uy * py, px, py], 1)  # (R, 4, K, n): s, c, dx, dy
    ox, oy = obs[..., 0], obs[..., 1]
    offsets = np.stack([ux[..., 0] * oy - uy[..., 0] * ox, -(ux[..., 0] * ox + uy[..., 0] * oy), -ox, -oy], 1)
    design = np.concatenate([rows.transpose(0, 1, 3, 2), offsets[:, :, None, :]], axis=2)
    wk = w[..., None]
    grad = np.stack([wk * px, -wk * py], 1)
    iu = np.triu_indices(n)

    def outer(a, b):
        return (a[..., :, None] * b[..., None, :])[..., iu[0], iu[1]]

    xy = outer(px, py) + outer(py, px)
    fisher = [_nonzero_columns(wk * outer(px, px)), _nonzero_columns(-wk * xy), _nonzero_columns(wk * outer(py, py))]
    data = BearingData(design, grad, tuple(f[0] for f in fisher), tuple(f[1] for f in fisher), w, n)
    return data.astype(dtype)


def _check(data: BearingData, theta) -> np.ndarray:
    theta = np.asarray(theta)
    if theta.ndim != 3 or theta.shape[0] != data.runs or theta.shape[2] != data.n:
        raise ValueError(f"theta must be (R, P, n) = ({data.runs}, P, {data.n}); got {theta.shape}")
    return theta


def _unpack(vec: np.ndarray, n: int) -> np.ndarray:
    """Symmetric ``(..., n, n)`` from upper triangles ``(..., n(n+1)/2)``."""
    out = np.empty((*vec.shape[:-1], n, n), vec.dtype)
    iu = np.triu_indices(n)
    out[..., iu[0], iu[1]] = vec
    out[..., iu[1], iu[0]] = vec
    return out


class Evaluator:
    """Evaluates ``lam`` and its derivatives for stacks ``theta (R, P, n)`` block by block,
    each block ``(runs, particles, K)`` about ``block`` numbers, in buffers kept from call
    to call.  Why: a fresh array per operation costs more than the arithmetic (the pages
    of every new megabyte are faulted in), and blocks that fit the cache run twice as fast
    as whole stacks (``benchmarks/batch_tma.py``).  Results are float64 whatever the
    data's dtype."""

    def __init__(self, data: BearingData, block: int = 2**16):
        self.data, self.block, self._buf = data, block, {}

    def _blocks(self, runs: int, particles: int):
        k = self.data.scans
        pb = min(particles, max(1, self.block // k))
        rb = max(1, self.block // (pb * k)) if pb == particles else 1
        for r0 in range(0, runs, rb):
            for p0 in range(0, particles, pb):
                yield slice(r0, min(r0 + rb, runs)), slice(p0, min(p0 + pb, particles))

    def _arrays(self, shape: tuple, names: str) -> list[np.ndarray]:
        out = []
        for name in names.split():
            key = (name, shape)
            if key not in self._buf:
                self._buf[key] = np.empty(shape, self.data.dtype)
            out.append(self._buf[key])
        return out

    def _linear(self, theta: np.ndarray, rs: slice, ps: slice, names: str) -> list[np.ndarray]:
        """``s, c`` (and ``dx, dy``) ``(r, p, K)`` of one block, in buffers."""
        t = theta[rs, ps]
        aug, = self._arrays((*t.shape[:2], t.shape[2] + 1), "aug")
        aug[..., :-1] = t
        aug[..., -1] = 1.0
        out = self._arrays((*t.shape[:2], self.data.scans), names)
        design = self.data.design[rs]
        for i, a in enumerate(out):
            np.matmul(aug, design[:, i], out=a)
        return out

    def _lam(self, e2: np.ndarray, rs: slice) -> np.ndarray:
        """``lam`` from the squared residuals ``e2 (r, p, K)``."""
        return 0.5 * (e2 @ self.data.weights[rs, :, None])[..., 0]

    def nll(self, theta) -> np.ndarray:
        """``lam (R, P)``, [Oliva2021, Eq. (10)]."""
        theta = _check(self.data, theta)
        out = np.empty(theta.shape[:2])
        for rs, ps in self._blocks(*theta.shape[:2]):
            s, c = self._linear(theta, rs, ps, "s c")
            out[rs, ps] = self._lam(atan2_into(s, c, squared=True), rs)
        return out

    def derivatives(self, theta, hessian: bool = False):
        """``lam (R, P)``, gradient ``M (R, P, n)`` and Fisher information (or with
        ``hessian=True`` the full Hessian) ``(R, P, n, n)``: see :func:`derivatives`."""
        theta = _check(self.data, theta)
        n = self.data.n
        lam, grad = np.empty(theta.shape[:2]), np.empty(theta.shape)
        mat = np.zeros((*theta.shape[:2], n * (n + 1) // 2))
        for rs, ps in self._blocks(*theta.shape[:2]):
            lam[rs, ps], grad[rs, ps] = self._derivatives(theta, rs, ps, hessian, mat[rs, ps])
        return lam, grad, _unpack(mat, n)

    def _derivatives(self, theta, rs, ps, hessian, mat):
        """One block: ``lam`` and the gradient; adds the matrix into ``mat`` (a view)."""
        s, c, dx, dy = self._linear(theta, rs, ps, "s c dx dy")
        spare, q = self._arrays(s.shape, "spare q")
        e = atan2_into(s, c)  # in s's buffer; c is only scratch from here on
        np.multiply(dx, dx, out=q)
        q += np.multiply(dy, dy, out=spare)
        with np.errstate(divide="ignore", invalid="ignore"):  # r = 0 (on the observer): non-finite derivatives
            dy /= q  # dy / r^2 = -rho_x
            dx /= q  # dx / r^2 = rho_y
        data = self.data
        # M = -sum e (rho_x Phi_x + rho_y Phi_y) / sigma^2; the bases hold Phi_x and -Phi_y
        gb = data.grad_basis[rs]
        grad = np.multiply(e, dy, out=q) @ gb[:, 0]
        grad += np.multiply(e, dx, out=q) @ gb[:, 1]
        # F = sum (rho_x^2 Phi_x Phi_x^T + rho_x rho_y (Phi_x Phi_y^T + Phi_y Phi_x^T) + rho_y^2 ...) / sigma^2
        coefs = [np.multiply(dy, dy, out=q), np.multiply(dy, dx, out=spare), np.multiply(dx, dx, out=c)]
        if hessian:  # - sum e d2h / sigma^2, d2h in (dx, dy) (module docstring); the xy basis has a minus
            two = 2 * e * dx * dy
            coefs = [coefs[0] - two, coefs[1] + e * (coefs[0] - coefs[2]), coefs[2] + two]
        for coef, basis, cols in zip(coefs, data.fisher_basis, data.fisher_cols):
            mat[..., cols] += coef @ basis[rs]
        return self._lam(np.square(e, out=e), rs), grad


def residuals(data: BearingData, theta) -> np.ndarray:
    """``e = wrap(z - h(theta)) (R, P, K)`` in (-pi, pi]."""
    theta = _check(data, theta)
    aug = np.concatenate([theta, np.ones((*theta.shape[:2], 1))], axis=-1).astype(data.dtype)
    return np.arctan2(aug @ data.design[:, 0], aug @ data.design[:, 1])


def nll(data: BearingData, theta) -> np.ndarray:
    """``lam = 1/2 sum_k e_k^2 / sigma_k^2 (R, P)``, [Oliva2021, Eq. (10)] ([Oh2021, Eq. (5)]: ``J = 2 lam``)."""
    return Evaluator(data).nll(theta)


def derivatives(data: BearingData, theta, hessian: bool = False):
    """``lam (R, P)``, gradient ``M (R, P, n)`` and Fisher information ``F (R, P, n, n)``
    (the Gauss-Newton matrix; with ``hessian=True`` the full Hessian of ``lam`` instead).
    A candidate on the observer (``r^2 = 0``) gets non-finite derivatives
    (:func:`cholesky_solve` reports them)."""
    return Evaluator(data).derivatives(theta, hessian)


def fisher(data: BearingData, theta) -> np.ndarray:
    """Fisher information ``F (R, P, n, n)`` at ``theta`` ([Oliva2021, Eq. (16)]); it does not depend
    on the measured bearings."""
    return derivatives(data, theta)[2]


def crlb(phi, observer, theta, sigma) -> np.ndarray:
    """The CRLB ``F(theta)^-1 (n, n)`` of an unbiased estimate of ``theta`` from bearings
    with std ``sigma`` (rad, scalar or ``(K,)``) ([Oliva2021, Sec. 2.5]; [Oh2021]'s bound)."""
    theta = np.asarray(theta, float)
    d = np.asarray(phi, float) @ theta - np.asarray(observer, float)
    data = prepare(phi, observer, np.arctan2(d[:, 1], d[:, 0]), np.broadcast_to(sigma, (len(d),))[None])
    bound, ok = spd_inverse(fisher(data, theta[None, None])[0])
    if not ok[0]:
        raise ValueError("the Fisher information is singular: these bearings do not determine theta")
    return bound[0]


def cholesky_solve(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Solve ``a x = b`` for a stack of small symmetric positive definite ``a (..., n, n)``,
    ``b (..., n)``, by a Cholesky factorisation written out over the n columns (numpy's
    batched LAPACK calls cost a microsecond per matrix; this costs about n^3 / 3 array
    operations for the whole stack).  Returns ``x``, ``det(a)`` and ``ok``, False where a
    pivot was not positive or not finite: there ``x = 0`` and ``det = 0``."""
    n = a.shape[-1]
    shape = a.shape[:-2]
    m = np.moveaxis(np.asarray(a, float).reshape(-1, n, n), 0, -1).copy()  # (n, n, N): rows of contiguous stacks
    y = np.asarray(b, float).reshape(-1, n).T.copy()
    ok = np.ones(m.shape[-1], bool)
    det = np.ones(m.shape[-1])
    with np.errstate(invalid="ignore"):
        for j in range(n):  # m's lower triangle becomes L, column by column
            for k in range(j):
                m[j, j] -= m[j, k] ** 2
            good = np.isfinite(m[j, j]) & (m[j, j] > 0)
            ok &= good
            det *= np.where(good, m[j, j], 0.0)
            m[j, j] = np.sqrt(np.where(good, m[j, j], 1.0))
            for i in range(j + 1, n):
                for k in range(j):
                    m[i, j] -= m[i, k] * m[j, k]
                m[i, j] /= m[j, j]
        for i in range(n):  # L z = b
            for k in range(i):
                y[i] -= m[i, k] * y[k]
            y[i] /= m[i, i]
        for i in reversed(range(n)):  # L^T x = z
            for k in range(i + 1, n):
                y[i] -= m[k, i] * y[k]
            y[i] /= m[i, i]
    x = y.T
    x[~ok] = 0.0
    return x.reshape(*shape, n), det.reshape(shape), ok.reshape(shape)


def spd_inverse(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Inverses ``(..., n, n)`` of symmetric positive definite matrices by
    :func:`cholesky_solve`, and ``ok``; NaN where ``a`` is not positive definite."""
    n = a.shape[-1]
    cols = [cholesky_solve(a, np.broadcast_to(e, a.shape[:-1])) for e in np.eye(n)]
    ok = cols[0][2]
    return np.where(ok[..., None, None], np.stack([c[0] for c in cols], -1), np.nan), ok


def solve_general(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Solve ``a x = b`` for a stack of small matrices by LU (for the full Hessian, which
    need not be definite).  Returns ``x`` and ``ok``, False where ``a`` is singular or not
    finite (there ``x = 0``)."""
    finite = np.isfinite(a).all(axis=(-1, -2)) & np.isfinite(b).all(axis=-1)
    safe = np.where(finite[..., None, None], a, np.eye(a.shape[-1]))
    ok = finite & (np.linalg.cond(safe) < 1 / np.finfo(float).eps)
    x = np.linalg.solve(np.where(ok[..., None, None], safe, np.eye(a.shape[-1])),
                        np.where(ok[..., None], b, 0.0)[..., None])[..., 0]
    return x, ok


@dataclass(frozen=True)
class NewtonResult:
    """:func:`gauss_newton` per run: ``theta (R, n)``, ``nll (R,)`` at theta, ``n_iter (R,)``
    steps taken, ``converged (R,)`` (the predicted decrease of ``lam`` fell to ``tol``),
    ``degenerate (R,)`` (a singular or non-finite Newton matrix or step stopped the run,
    or with the line search no step length lowered ``lam`` short of convergence;
    ``theta`` is its last finite iterate)."""

    theta: np.ndarray
    nll: np.ndarray
    n_iter: np.ndarray
    converged: np.ndarray
    degenerate: np.ndarray


HALVINGS = 30  # step lengths 1, 1/2, ..., 2^-29 tried by the line search, in one evaluation


def gauss_newton(data: BearingData, theta0, max_iter: int = 50, tol: float = 1e-9,
                 hessian: bool = False, line_search: bool = False) -> NewtonResult:
    """Newton-Raphson on ``lam`` for every run from ``theta0 (R, n)``:
    ``theta <- theta - a A^-1 M`` with ``A`` the Fisher information (Gauss-Newton, Fisher
    scoring) or, with ``hessian=True``, the full Hessian ([Oh2021, Eq. (6)-(7)]).

    ``line_search=False`` (the paper's, and its divergence): ``a = 1``, no bounds.
    ``line_search=True`` (damped): ``a`` is the longest of 1, 1/2, ... 2^-29 that lowers
    ``lam`` (Armijo with a zero slope fraction; all tried in one vectorised evaluation),
    so ``lam`` never rises and the iterates cannot run away to 1e10 m from a start whose
    full step overshoots; a run where no step length lowers ``lam`` stops (at a minimum to
    rounding if its predicted decrease is within ``tol``, else not converged).

    A run stops when the step's predicted decrease ``1/2 |M^T A^-1 M|`` is at most ``tol``
    (in units of ``lam``; the noise moves ``lam`` by about ``n / 2``), after ``max_iter``
    steps, or when ``A`` is singular or not finite.  Evaluates in float64 whatever
    ``data.dtype``."""
    if data.dtype != np.float64:
        data = data.astype(np.float64)
    theta = np.array(theta0, float).reshape(data.runs, 1, data.n)
    n_iter = np.zeros(data.runs, int)
    converged, degenerate = np.zeros(data.runs, bool), np.zeros(data.runs, bool)
    ev = Evaluator(data)
    lengths = 0.5 ** np.arange(HALVINGS)
    for _ in range(max_iter):
        active = ~(converged | degenerate)
        if not active.any():
            break
        lam, grad, mat = (a[:, 0] for a in ev.derivatives(theta, hessian))
        if hessian:
            step, ok = solve_general(mat, -grad)
        else:
            step, _, ok = cholesky_solve(mat, -grad)
        ok &= np.isfinite(lam) & np.isfinite(theta[:, 0] + step).all(-1)
        degenerate |= active & ~ok
        move = active & ok
        small = 0.5 * np.abs(np.einsum("ri,ri->r", grad, step)) <= tol
        if line_search and move.any():
            rows = np.flatnonzero(move)
            trial = theta[rows] + lengths[None, :, None] * step[rows, None, :]  # (m, HALVINGS, n)
            lower = ev_rows(data, rows).nll(trial) < lam[rows, None]
            found = lower.any(axis=1)
            step[rows] *= np.where(found, lengths[np.argmax(lower, axis=1)], 0.0)[:, None]
            stuck = np.zeros(data.runs, bool)
            stuck[rows[~found]] = True
            converged |= stuck & small  # no length lowers lam: at the minimum, to rounding
            degenerate |= stuck & ~small  # ... or stalled short of it
            move &= ~stuck
        theta[move, 0] += step[move]
        n_iter += move
        converged |= move & small
    return NewtonResult(theta[:, 0], ev.nll(theta)[:, 0], n_iter, converged, degenerate)


def ev_rows(data: BearingData, rows: np.ndarray) -> Evaluator:
    """An :class:`Evaluator` of the runs ``rows`` of ``data``."""
    return Evaluator(data.take(rows) if len(rows) != data.runs else data)
