"""Intelligence-aware batch MLE: bearings plus "the track stays inside these sets and
outside those", and its Cramer-Rao bounds.

[Oliva2021] (Oliva, Farina, Setola 2021), Sec. 2.  A target with
``p(t) = Q(t) psi`` (Eq. 11-12; :func:`.batch.polynomial_basis`, order 2:
``psi = [x0, y0, vx, vy, ax, ay]``) is seen in bearings ``z_k = h_k(psi) + w_k`` from +x,
anticlockwise, ``h = atan2(dy, dx)`` (Eq. 3, :mod:`.batch`'s convention; nothing to
convert).  Intelligence says that at every sample time ``t_k`` (Eq. 13: ``k = 0..k_max``,
also the time before the first bearing) the target is inside every disc ``X_i`` and
outside every disc ``Y_i`` (Eq. 4-5, 14).

* Constraint functions (Eq. 14, ``g(Q(k) psi) <= 0``), one per set and sample time:
  ``g = (|p - c|^2 - r^2) / (2 r)`` inside ``X_i`` and its negative outside ``Y_i``.  The
  form is smooth everywhere (the distance ``|p - c| - r`` is not at the centre), equals
  the signed distance to the circle to first order (so tolerances are in metres) and has
  ``d g / d psi = +-Q(k)^T (p - c) / r``, ``d2 g / d psi2 = +-Q(k)^T Q(k) / r``.
* MLE (Eq. 10) and constrained MLE (Eq. 14, ``min lam(psi)`` subject to every
  ``g <= 0``), :func:`solve`: from the pseudo-linear estimate (:func:`pseudo_linear`),
  Levenberg-Marquardt on all runs and starts at once (:func:`levenberg_marquardt`); with
  constraints, SLSQP from there in parameters scaled by the CRLB's standard deviations
  with the analytic Jacobian of every constraint (:func:`slsqp`).
* Artificial potential field (Sec. 2.7): :func:`apf_force`, :func:`heading`.
* Unconstrained CRLB (Eq. 16): :func:`.batch.crlb`.  Constrained CRLB (Sec. 2.6):
  :func:`constrained_crlb`, which says how it treats inactive, boundary and nearly
  collinear constraints.

Shapes: R runs, P starts per run, K bearings, ``Kc`` constraint times, S sets.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from .batch import BearingData, Evaluator, cholesky_solve, spd_inverse


@dataclass(frozen=True)
class Disc:
    """A disc with ``centre (2,)`` (m) and ``radius`` (m): [Oliva2021, Table 1]'s sets."""

    centre: tuple[float, float]
    radius: float

    def __post_init__(self):
        c = np.asarray(self.centre, float)
        if c.shape != (2,) or not np.isfinite(c).all():
            raise ValueError(f"a disc's centre must be two finite numbers; got {self.centre!r}")
        if not (np.isfinite(self.radius) and self.radius > 0):
            raise ValueError(f"a disc's radius must be a positive number of metres; got {self.radius!r}")

    @property
    def area(self) -> float:
        return float(np.pi * self.radius**2)


@dataclass(frozen=True)
class Intelligence:
    """[Oliva2021, Eq. (4)-(5)]: the target is inside every disc of ``inside`` (their intersection
    must not be empty) and outside every disc of ``outside``.

    As arrays over the S sets, inside first: ``centres (S, 2)``, ``radii (S,)``,
    ``signs (S,)`` (+1 inside, -1 outside), so that ``g_s(p) = signs_s (|p - c_s|^2 -
    r_s^2) / (2 r_s) <= 0`` is the requirement."""

    inside: tuple[Disc, ...] = ()
    outside: tuple[Disc, ...] = ()

    def __post_init__(self):
        object.__setattr__(self, "inside", tuple(self.inside))
        object.__setattr__(self, "outside", tuple(self.outside))
        if not all(isinstance(d, Disc) for d in self.inside + self.outside):
            raise ValueError("intelligence sets must be Disc objects")

    @property
    def sets(self) -> tuple[Disc, ...]:
        return self.inside + self.outside

    @property
    def centres(self) -> np.ndarray:
        return np.array([d.centre for d in self.sets], float).reshape(-1, 2)

    @property
    def radii(self) -> np.ndarray:
        return np.array([d.radius for d in self.sets], float)

    @property
    def signs(self) -> np.ndarray:
        return np.concatenate([np.ones(len(self.inside)), -np.ones(len(self.outside))])

    def values(self, p) -> np.ndarray:
        """``g (..., S)`` at positions ``p (..., 2)``: at most 0 where the requirement holds;
        to first order the distance (m) by which a position violates it."""
        p = np.asarray(p, float)
        c, r = self.centres, self.radii
        # one set at a time on whole (...) arrays: numpy is slow on a last axis of 2 or 3
        # (3.5x for a swarm of 90 tracks x 1801 times); |p - c|^2 = x (x - 2 cx) + y (y - 2 cy)
        # + |c|^2 rounds by 1e-16 of |p|^2 ~ 1e10 m^2, 1e-11 m of g
        x, y = np.ascontiguousarray(p[..., 0]), np.ascontiguousarray(p[..., 1])
        out = np.empty((*p.shape[:-1], len(r)))
        for s, (sign, (cx, cy), rad) in enumerate(zip(self.signs, c, r)):
            out[..., s] = (sign / (2 * rad)) * (x * (x - 2 * cx) + y * (y - 2 * cy) + (cx**2 + cy**2 - rad**2))
        return out

    def gradients(self, p) -> np.ndarray:
        """``d g / d p (..., S, 2) = +-(p - c) / r``."""
        rel = np.asarray(p, float)[..., None, :] - self.centres
        return (self.signs / self.radii)[:, None] * rel


@dataclass(frozen=True, eq=False)
class TrackConstraints:
    """:class:`Intelligence` imposed on a track ``p_k = phi_k theta`` at the ``Kc``
    constraint times ([Oliva2021, Eq. (13)-(14)]): ``phi (Kc, 2, n)``.  The constraint ``j`` is the pair
    (time k, set s); arrays of them are ``(..., Kc, S)``."""

    intelligence: Intelligence
    phi: np.ndarray

    def __post_init__(self):
        phi = np.asarray(self.phi, float)
        if phi.ndim != 3 or phi.shape[1] != 2 or len(phi) == 0 or not np.isfinite(phi).all():
            raise ValueError(f"phi must be a finite (Kc, 2, n) array; got shape {phi.shape}")
        if not self.intelligence.sets:
            raise ValueError("no intelligence sets to impose")
        object.__setattr__(self, "phi", phi)

    @property
    def n(self) -> int:
        return self.phi.shape[2]

    @property
    def times(self) -> int:
        return self.phi.shape[0]

    def positions(self, theta) -> np.ndarray:
        """``p (..., Kc, 2)`` of parameters ``theta (..., n)``."""
        theta = np.asarray(theta, float)
        return (theta @ self.phi.reshape(-1, self.n).T).reshape(*theta.shape[:-1], self.times, 2)

    def values(self, theta) -> np.ndarray:
        """``g (..., Kc, S)``: Eq. (14)'s ``g_k(theta)``, at most 0 when feasible."""
        return self.intelligence.values(self.positions(theta))

    def jacobian(self, theta) -> np.ndarray:
        """``d g / d theta (..., Kc, S, n) = phi_k^T d g / d p``."""
        grad_p = self.intelligence.gradients(self.positions(theta))  # (..., Kc, S, 2)
        return np.einsum("...ksa,kan->...ksn", grad_p, self.phi)

    def violation(self, theta) -> np.ndarray:
        """``max(0, max_j g_j) (...)``: how far (m) the track leaves the allowed region."""
        return np.maximum(self.values(theta).max(axis=(-1, -2)), 0.0)


def pseudo_linear(data: BearingData) -> np.ndarray:
    """The pseudo-linear estimate ``theta (R, n)`` of every run: the least-squares solution
    of ``s_k(theta) = sin(z_k) dx_k - cos(z_k) dy_k = 0`` (the bearing line through the
    observer), linear in ``theta`` (:mod:`.batch` holds its rows, ``design[:, 0]``), with
    the columns scaled to unit norm before a QR factorisation (their norms span ten
    decades for a constant-acceleration track).  Biased (the classic PLE bias, growing
    with range and noise), it is a start, not an estimate.  Raises ValueError when the
    bearings do not determine ``theta`` (rank-deficient rows)."""
    rows = np.swapaxes(data.design[:, 0, :-1], 1, 2).astype(float)  # (R, K, n)
    rhs = -data.design[:, 0, -1].astype(float)  # (R, K)
    w = np.sqrt(data.weights.astype(float))[..., None]
    rows, rhs = rows * w, rhs * w[..., 0]
    scale = np.sqrt((rows**2).sum(1))  # (R, n)
    if not (scale > 0).all():
        raise ValueError("the pseudo-linear rows have a zero column: the bearings do not determine theta")
    q, r = np.linalg.qr(rows / scale[:, None])
    diag = np.abs(np.diagonal(r, axis1=1, axis2=2))
    if (diag <= 1e-12 * diag.max(1, keepdims=True)).any():
        raise ValueError("the pseudo-linear equations are rank-deficient: the bearings do not determine theta")
    x = np.linalg.solve(r, np.einsum("rkn,rk->rn", q, rhs)[..., None])[..., 0]
    return x / scale


@dataclass(frozen=True)
class Settings:
    """The local solvers' settings (:func:`solve`).

    ``max_iter``: Levenberg-Marquardt steps (unconstrained) or SLSQP iterations
    (constrained).  ``tol``: Levenberg-Marquardt stops when the undamped Gauss-Newton step
    predicts a decrease of ``lam`` of at most ``tol`` (the noise moves ``lam`` by about
    ``n / 2``); SLSQP's ``ftol``.  ``feas_tol`` (m): the largest violation a converged
    constrained solution may have (the paper's MIDACO ran with a feasibility accuracy of
    0.001)."""

    max_iter: int = 200
    tol: float = 1e-8
    feas_tol: float = 1e-3


@dataclass(frozen=True)
class Result:
    """:func:`solve` per run and start: ``theta (R, P, n)``, ``nll (R, P)``, the largest
    constraint violation ``violation (R, P)`` (m; 0 without constraints), ``converged
    (R, P)``, ``n_iter (R, P)`` and, with constraints, the multipliers ``multipliers
    (R, P, Kc, S)`` (KKT: ``grad lam + sum y grad g = 0``, ``y >= 0``)."""

    theta: np.ndarray
    nll: np.ndarray
    violation: np.ndarray
    converged: np.ndarray
    n_iter: np.ndarray
    multipliers: np.ndarray | None


def solve(data: BearingData, theta0, constraints: TrackConstraints | None = None,
          settings: Settings = Settings()) -> Result:
    """The MLE of [Oliva2021, Eq. (10)], or with ``constraints`` the constrained MLE of Eq. (14),
    for every run and start ``theta0 (R, P, n)`` or ``(R, n)``.

    Unconstrained: Levenberg-Marquardt on all runs and starts at once
    (:func:`levenberg_marquardt`).  Constrained: SLSQP (:func:`slsqp`) one problem at a
    time.  Raises ValueError on shapes that do not fit or non-finite starts."""
    if data.dtype != np.float64:
        data = data.astype(np.float64)
    theta = np.array(theta0, float)
    if theta.ndim == 2:
        theta = theta[:, None]
    if theta.ndim != 3 or theta.shape[0] != data.runs or theta.shape[2] != data.n:
        raise ValueError(f"theta0 must be (R, n) or (R, P, n) with R = {data.runs}, n = {data.n}; "
                         f"got {np.shape(theta0)}")
    if not np.isfinite(theta).all():
        raise ValueError("theta0 has non-finite values")
    if constraints is None:
        return levenberg_marquardt(data, theta, settings)
    if constraints.n != data.n:
        raise ValueError(f"the constraints' track has {constraints.n} parameters, the bearings' {data.n}")
    return slsqp(data, theta, constraints, settings)


def levenberg_marquardt(data: BearingData, theta: np.ndarray, settings: Settings = Settings()) -> Result:
    """Levenberg-Marquardt on ``lam`` from ``theta (R, P, n)`` for all runs and starts as one
    batch, each with its own damping: the Gauss-Newton (Fisher) matrix ``F`` with
    Marquardt's ``mu diag(F)`` (steps invariant to the parameters' units: metres against
    m/s^2 span twelve decades), Nielsen's damping update, a step taken when it achieves
    1e-4 of its predicted decrease.  A problem is done after the step at which the
    undamped step predicts at most ``settings.tol`` (the damped step's prediction is small whenever the damping is
    large, done or not).  A step whose damped matrix is not positive definite or whose
    trial point is not finite is rejected with more damping: no estimate turns into NaN."""
    ev = Evaluator(data)
    n = theta.shape[-1]
    theta = theta.copy()
    lam = ev.nll(theta)
    mu, nu = np.full(lam.shape, 1e-3), np.full(lam.shape, 2.0)
    n_iter, done = np.zeros(lam.shape, int), np.zeros(lam.shape, bool)
    for _ in range(settings.max_iter):
        if done.all():
            break
        _, grad, mat = ev.derivatives(theta)
        diag = np.diagonal(mat, axis1=-2, axis2=-1)
        diag = np.maximum(diag, 1e-12 * diag.max(-1, keepdims=True))[..., None] * np.eye(n)
        newton, _, newton_ok = cholesky_solve(mat + 1e-12 * diag, -grad)
        small = newton_ok & (-0.5 * np.einsum("rpi,rpi->rp", grad, newton) <= settings.tol)
        step, _, ok = cholesky_solve(mat + mu[..., None, None] * diag, -grad)
        pred = -(np.einsum("rpi,rpi->rp", grad, step) + 0.5 * np.einsum("rpi,rpij,rpj->rp", step, mat, step))
        trial = theta + step
        lam_t = ev.nll(trial)
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = (lam - lam_t) / pred
        good = ~done & ok & (pred > 0) & np.isfinite(lam_t) & np.isfinite(trial).all(-1) & (ratio > 1e-4)
        bad = ~done & ~good
        theta[good], lam[good] = trial[good], lam_t[good]
        mu[good] *= np.maximum(1 / 3, 1 - (2 * ratio[good] - 1) ** 3)
        nu[good] = 2.0
        mu[bad] = np.minimum(mu[bad] * nu[bad], 1e300)
        nu[bad] *= 2
        n_iter += ~done
        done |= small  # after this last step: it takes lam the rest of the way
    return Result(theta, lam, np.zeros(lam.shape), done, n_iter, None)


def slsqp(data: BearingData, theta: np.ndarray, constraints: TrackConstraints,
          settings: Settings = Settings()) -> Result:
    """The constrained MLE (Eq. 14) by scipy's SLSQP from each start of ``theta (R, P, n)``,
    with the analytic gradient of ``lam`` and Jacobian of every constraint ``g_k <= 0``
    (all ``Kc x S`` of them), in parameters scaled by the square roots of the diagonal of
    ``F^-1`` at the start (the CRLB's standard deviations: unit steps in every direction;
    metres and m/s^2 unscaled span twelve decades and SLSQP stalls).

    One problem at a time (scipy solves one; about 10 iterations and 0.02 s per problem
    for [Oliva2021]'s study).  Why not a batched augmented Lagrangian: tried first, its
    Levenberg-Marquardt inner problems stall where the active constraint switches between
    sample times along a curved circle, and stopped up to 1.6 standard deviations short of
    the optimum SLSQP finds (5 of 8 runs of the APF geometry; docs/results/oliva2021.md).
    ``converged``: SLSQP reported success and the violation is within ``feas_tol``."""
    r, p, n = theta.shape
    out = {k: np.zeros((r, p)) for k in ("nll", "violation", "converged", "n_iter")}
    x_out, y_out = np.empty_like(theta), np.zeros((r, p, constraints.times, len(constraints.intelligence.sets)))
    fim = Evaluator(data).derivatives(theta)[2]
    for i in range(r):
        ev = Evaluator(data.take([i]))
        for j in range(p):
            res = _slsqp_one(ev, theta[i, j], fim[i, j], constraints, settings)
            x_out[i, j], y_out[i, j] = res.x, res.multipliers
            out["nll"][i, j], out["n_iter"][i, j], out["converged"][i, j] = res.fun, res.nit, res.success
    out["violation"] = constraints.violation(x_out)
    converged = out["converged"].astype(bool) & (out["violation"] <= settings.feas_tol)
    return Result(x_out, out["nll"], out["violation"], converged, out["n_iter"].astype(int), y_out)


def _slsqp_one(ev: Evaluator, start: np.ndarray, fim: np.ndarray, constraints: TrackConstraints,
               settings: Settings):
    """One SLSQP solve in scaled parameters ``u``, ``theta = start + scale u``; returns an
    object with ``x`` (theta), ``fun``, ``nit``, ``success`` and ``multipliers``
    ``(Kc, S)`` (zero where SLSQP reports none)."""
    diag = np.diagonal(fim)
    inv, ok = spd_inverse(fim)
    scale = np.sqrt(np.diagonal(inv)) if ok and np.isfinite(inv).all() else 1 / np.sqrt(np.maximum(diag, 1e-300))
    if not (np.isfinite(scale).all() and (scale > 0).all()):
        scale = np.maximum(np.abs(start), 1.0)

    def point(u):
        return (start + scale * u)[None, None]

    def fun(u):
        return float(ev.nll(point(u))[0, 0])

    def jac(u):
        return ev.derivatives(point(u))[1][0, 0] * scale

    cons = {"type": "ineq", "fun": lambda u: -constraints.values(start + scale * u).reshape(-1),
            "jac": lambda u: -(constraints.jacobian(start + scale * u).reshape(-1, len(start)) * scale)}
    res = minimize(fun, np.zeros(len(start)), jac=jac, constraints=[cons], method="SLSQP",
                   options={"maxiter": settings.max_iter, "ftol": settings.tol})
    res.x = start + scale * res.x
    mult = getattr(res, "multipliers", None)
    res.multipliers = np.zeros(constraints.times * len(constraints.intelligence.sets)) if mult is None else mult
    res.multipliers = np.asarray(res.multipliers, float).reshape(constraints.times, -1)
    if not np.isfinite(res.x).all():  # never hand back NaN: keep the start and report failure
        res.x, res.fun, res.success = start.copy(), float(ev.nll(start[None, None])[0, 0]), False
    return res


@dataclass(frozen=True)
class ConstrainedBound:
    """:func:`constrained_crlb`'s answer: the bound ``(n, n)``, the number of constraints
    counted as active, the rank of their whitened Jacobian and its singular values
    relative to the largest (descending; empty without active constraints)."""

    bound: np.ndarray
    active: int
    rank: int
    singular_values: np.ndarray


def constrained_crlb(bound, gradients, values, tol: float = 0.0, rcond: float = 1e-9) -> ConstrainedBound:
    """[Oliva2021, Sec. 2.6]: ``C - C F (F^T C F)^-1 F^T C`` with ``C = J^-1`` the unconstrained
    bound ``bound (n, n)`` and ``F`` the generalised Jacobian of ``max(g, 0)``, from the
    constraints' gradients ``(..., n)`` and values ``(...)`` at the point (e.g.
    :meth:`TrackConstraints.jacobian` and ``.values`` at the truth).

    * Inactive constraints (``g < -tol``): their column of ``F`` is zero; they drop out.
    * Violated constraints (``g > tol``): the column is ``grad g``.
    * Constraints on the kink (``|g| <= tol``): the generalised Jacobian is the segment
      ``{t grad g, t in [0, 1]}``.  The formula depends on the column space of ``F`` only,
      so every ``t > 0`` gives the bound with the constraint and ``t = 0`` the bound
      without it, which is the larger in the PSD order; Eq. (23)'s worst case over the set
      therefore drops them (with the default ``tol = 0`` only exact zeros are on the kink).
    * Nearly collinear constraints (neighbouring sample times of one set give gradients
      that agree to 1e-8 and closer): with ``C = S S^T`` (Cholesky) the bound is
      ``S (I - U U^T) S^T``, ``U`` the left singular vectors of the whitened Jacobian
      ``S^T F`` (columns scaled to unit norm, so units and counts do not matter) whose
      singular values exceed ``rcond`` times the largest.  Whitening makes the rank
      decision independent of the parameters' units; ``rcond`` decides how many
      directions count and the bound depends on it steeply (docs/results/oliva2021.md): an
      equality-constrained bound is not continuous in the constraints.  The default 1e-9
      sits above the rounding of the gradients (relative 1e-13 and the cancellation in
      ``p - c``) and below the smallest direction we regard as real.

    References: [Oliva2021] Sec. 2.6, Eq. (17), (23).
    """
    c = np.asarray(bound, float)
    n = c.shape[-1]
    grads = np.asarray(gradients, float).reshape(-1, n)
    g = np.asarray(values, float).reshape(-1)
    if len(grads) != len(g):
        raise ValueError(f"{len(grads)} gradients for {len(g)} constraint values")
    if not (np.isfinite(c).all() and np.isfinite(grads).all() and np.isfinite(g).all()):
        raise ValueError("the bound, gradients and values must be finite")
    s = np.linalg.cholesky(c)  # LinAlgError when the bound is not positive definite
    f = grads[g > tol].T  # (n, q)
    if f.shape[1] == 0:
        return ConstrainedBound(c.copy(), 0, 0, np.zeros(0))
    w = s.T @ f
    norms = np.linalg.norm(w, axis=0)
    w = w[:, norms > 0] / norms[norms > 0]
    u, sv, _ = np.linalg.svd(w, full_matrices=False)
    rank = int((sv > rcond * sv[0]).sum()) if len(sv) else 0
    proj = np.eye(n) - u[:, :rank] @ u[:, :rank].T
    out = s @ proj @ s.T
    return ConstrainedBound(0.5 * (out + out.T), f.shape[1], rank, sv / sv[0] if len(sv) else sv)


def apf_force(intelligence: Intelligence, weighting: str = "area", at=(0.0, 0.0)) -> np.ndarray:
    """[Oliva2021, Sec. 2.7]: the artificial potential field's force ``f (2,)`` at ``at`` (the
    ownship's start): ``f = sum_i alpha_i (x_i - p) - sum_i beta_i (y_i - p)`` with
    ``x_i``, ``y_i`` the centres of the inside and outside discs (the printed
    ``f(0) = sum alpha_i x_i - sum beta_i y_i``; the printed potential ``U`` has the
    opposite sign, its antigradient would repel from ``X_i``, so we take the stated force).

    ``weighting``: ``"area"`` as the text says (``alpha_i = 1 / area(X_i)``,
    ``beta_i = area(Y_i)``) or ``"caption"`` as Fig. 1's caption (``alpha_i = area(X_i)``,
    ``beta_i = 1 / area(Y_i)``).  Neither gives the published 0.749 rad for Table 1's sets
    (docs/results/oliva2021.md; :func:`heading` converts).

    References: [Oliva2021] Sec. 2.7."""
    if weighting not in ("area", "caption"):
        raise ValueError(f"weighting must be 'area' or 'caption'; got {weighting!r}")
    p = np.asarray(at, float)
    f = np.zeros(2)
    for d in intelligence.inside:
        f += (1 / d.area if weighting == "area" else d.area) * (np.asarray(d.centre) - p)
    for d in intelligence.outside:
        f -= (d.area if weighting == "area" else 1 / d.area) * (np.asarray(d.centre) - p)
    return f


def heading(force) -> dict:
    """The direction of ``force (2,)`` both ways [Oliva2021] states it (rad): ``from_x`` (Eq. 18
    rotates the track anticlockwise from +x by gamma) and ``from_y`` (the text: "the angle
    between [0 1]^T and f", taken anticlockwise from +y)."""
    fx, fy = np.asarray(force, float)
    if fx == 0 and fy == 0:
        raise ValueError("the potential field's force is zero: no direction")
    return {"from_x": float(np.arctan2(fy, fx)), "from_y": float(np.arctan2(-fx, fy))}
