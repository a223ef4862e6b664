"""The tracking accuracy floor: posterior Cramer-Rao lower bound of the closed loop.

For each target j of [Papaioannou2023], along the flown sensor path, the bound
``P_k = J_k^-1`` on the error covariance of any estimator of ``x_k`` from all scans up to
k, with the missed detections and Poisson clutter of Eq. (4).  Bearings follow [Papaioannou2023]:
``l(x, s) = atan2(dx, dy)`` from +y (north), clockwise, ``d = x - s``.

**Recursion.** Target model Eq. (1)-(2): ``x_{k+1} = A x_k + B u_k + v_k``,
``v ~ N(0, Q)``, ``x_0 ~ N(mu_0, Sigma_0)``.  For additive Gaussian noise the recursion of
[Tichavsky1998, Eq. (21)] (with linear dynamics) reads

    J_0 = Sigma_0^-1,    J_{k+1} = (Q + A J_k^-1 A^T)^-1 + E[J_Z(x_{k+1}, s_{k+1})].

Known controls ``B u_k`` move the mean only and drop out of every derivative with
respect to x.  That stays true in the closed loop, where the targets' controls and the
sensor positions ``s_k`` are functions of past scans: the joint density still factors
into prior x transitions x scan likelihoods, its Hessian in ``x_{0:k}`` keeps the same
block-tridiagonal form, and only the expectation of the scan term runs over the joint
law of truth, path and scans.  A Monte-Carlo campaign samples that law, so
``E[J_Z]`` is the average over trials of ``J_Z`` at each trial's true state and sensor
positions (over trials, not over targets: every target has its own bound).

**One scan's information.** On target j's channel a sensor at s receives the target
bearing with probability ``p_D`` (noise ``N(0, sigma^2)``) and ``Poisson(Lambda)`` false
alarms uniform on the circle, density ``lambda_c = Lambda / (2 pi)``.  Eq. (10) with
``p(phi) = 1 / 2pi`` is

    g(Z | x) = e^-Lambda lambda_c^n [ (1 - p_D) + (p_D / lambda_c) sum_i N(z_i; l(x, s), sigma^2) ].

With residuals ``u_i = wrap(z_i - l) / sigma`` and ``lambda_u = lambda_c sigma`` (false
alarms per unit sigma), the score is the bearing gradient times a scalar,

    grad_x log g = (h / sigma) psi,   psi = p_D sum_i phi(u_i) u_i / (lambda_u (1 - p_D) + p_D sum_i phi(u_i)),
    h = grad_x l = (dy, -dx, 0, ...) / r^2,  r^2 = dx^2 + dy^2,  phi the N(0, 1) density,

so ``J_Z = E[score score^T] = q2 h^T h / sigma^2`` with the scalar information reduction
factor (IRF) ``q2 = E[psi^2]`` (the scalar IRF of Niu, Willett & Bar-Shalom, "Matrix
CRLB scaling due to measurements of uncertain origin", IEEE TSP 2001, and of Zhang,
Willett & Bar-Shalom, "Dynamic Cramer-Rao bound for target tracking in clutter", IEEE
TAES 2005).  The clutter is uniform on the circle, so the law of the residual set does
not depend on l: q2 is one number per sensor, and it depends on sigma and Lambda only
through ``lambda_u``.  Its
expectation runs over everything in the scan: detected or not, how many false alarms and
where.  So ``p_D`` is inside q2, not a separate factor: with ``Lambda = 0`` a detection
gives ``psi = u_0`` and a miss gives ``psi = 0`` (g is flat), hence ``q2 = p_D`` -- the IRF
of missed detections (Hernandez, Ristic, Farina & Timmoneri, IEEE TSP 52(9), 2004,
Sec. III-A) -- and ``q2 = 1`` with ``p_D = 1``: the standard bound.  With clutter q2
falls below ``p_D`` (a miss among false alarms still carries a little information,
which the expectation counts).  This is the IRF bound: the expectation of the
information.  Conditioning on the detection sequence (ENUM) gives a tighter bound,
equal to the random-finite-set bound ([Hernandez2004]; Tong, Zhang, Meng & Wang,
Sensors 12(12), 2012); it is not implemented here.

**Computing q2.** The clutter residuals are a Poisson process of intensity ``lambda_u``
on ``|u| <= pi / sigma``; the target residual ``u_0 ~ N(0, 1)`` is present with
probability ``p_D``.  With ``1 / D^2 = int_0^inf t e^{-t D} dt`` for the denominator D and
the Laplace functional of the Poisson process (Campbell's theorem), ``tau = p_D t``:

    q2 = int_0^inf tau e^{-c tau} G(tau) [ lambda_u K(tau) (1 - p_D + p_D L(tau)) + p_D M(tau) ] dtau,
    c = lambda_u (1 - p_D) / p_D,   G = exp(-lambda_u int (1 - e^{-tau phi}) du),
    K = int phi^2 u^2 e^{-tau phi} du,   L = int phi e^{-tau phi} du,   M = int phi^3 u^2 e^{-tau phi} du

(G and K over the clutter window, L and M over the line).  With ``Lambda = 0``:
``q2 = p_D int tau M dtau = p_D int phi u^2 du = p_D``.  Quadrature: ``tau = e^s`` and the
trapezoid rule on uniform grids in s and u; for these analytic, fast-decaying integrands
it converges geometrically (Trefethen & Weideman, SIAM Review 56(3), 2014).  Measured:
the default grids agree with 2x and 4x finer, wider ones to about 1e-13 (tests), and with a
Monte Carlo through :func:`uavsim.sensing.observe` and
:func:`uavsim.sensing.log_likelihood` within its standard error.  The bearing noise is
taken as Gaussian on the line, so sigma is limited to ``pi / 8``, where the wrapped tail
``2 Phi(-pi / sigma)`` is below 1e-15.

**Numerics.** The recursion runs on the covariance ``P = J^-1``: predict
``P- = A P A^T + Q``, then the Woodbury form of ``(P-^-1 + E^T W E)^-1``,

    P = P- - P- E^T W (I + E P- E^T W)^-1 E P-,   W = E[J_Z] on (x, y),  E = [I_2, 0],

whose 2x2 system has eigenvalues >= 1.  No inverse of Q, Sigma_0 or P is ever formed,
so the paper's 1e-10 z variances, a singular Q (a noise-free truth model) or an exact
prior are all fine; this equals the information form (tested against the inverse of the
batch Fisher information), and when A, Q and Sigma_0 decouple the horizontal states from
z (as the paper's do) the (x, y) block equals that of the 4-D subsystem [x, y, vx, vy]
(tested).

**Output.** ``sqrt(tr)`` of the (x, y) block bounds the position RMSE of target j at
step k; its mean over targets is comparable with the ``rmse`` curve of a campaign summary
([Papaioannou2023, Sec. VI-B]: per target ``sqrt(mean over trials |error|^2)``, averaged over targets).

**Which truth it bounds.** The recursion is the bound of the model it is given: A, Q and
controls known to the estimator.  The simulator's truths are not that model: their
controls are P1's answer to their own state, a feedback that pulls every start towards
the goal.  Measured on the paper mission (20 trials, benchmarks/pcrlb.py): with no sensor
and ``truth = "stochastic"`` the recursion with Q gives 71.7 m where the prediction's RMSE
is 58.2 m, so it is no floor there.

For the paper's ``truth = "planned"`` the exact bound is :func:`pcrlb_planned`: the true
state is a deterministic function of the drawn start, ``x_k = g_k(x_0)``, with sensitivity
``G_k = d g_k / d x_0`` (:attr:`uavsim.truth.Truth.sensitivity`).  Every scan's score is
``G_j^T`` times the scan's score in ``x_j``, so the Bayesian information on ``x_0`` from
scans 1..k is ``J_k = Sigma_0^-1 + sum_j E[G_j^T E^T W_j E G_j]``, and the Van Trees
bound for the function ``g_k`` ([VanTrees2007], the bound for a function of the
parameter) is ``P_k >= E[G_k] J_k^-1 E[G_k]^T``, all on ``[x, y, vx, vy]`` and the
expectations averaged over trials.  Campaigns report that bound for planned truths and
none for stochastic ones (its recursion would need the Jacobian of the truth's feedback
``A + B du/dx`` at every step; not built).

**What it is not.** The expectations are averages over the campaign's trials, so the
bound is a Monte-Carlo estimate: :meth:`Bound.standard_error` is its jackknife standard
error over the trials [Efron1981] (a few trials bias it upward: the averages sit inside an
inverse).  It bounds the RMSE averaged over truths drawn from the prior, not each path's.

**Which prior.** The simulator draws true starts from ``N(mu_0, Sigma_0)`` restricted to
the starts that can stay out of every building, so campaigns pass as ``cov0`` that
restricted prior's covariance (:func:`uavsim.truth.start_prior`, from 4000 draws; it is
``Sigma_0`` itself where nothing is cut), and the expectations over ``G`` and ``W`` already
run over the restricted starts, since the trials draw from it.  With a cut prior this is
the Van Trees bound of the Gaussian with the restricted prior's covariance, not a strict
one: the Van Trees inequality needs a prior that vanishes on its support's edge, and a
cut Gaussian does not (its own Fisher information is unbounded there).  Its error is one
way: among priors with a given covariance the Gaussian has the least Fisher information,
so an estimator that uses the cut's shape (the filter's ``keep_out`` does) may still beat
it where much is cut; campaign summaries report each target's share kept and check the
bound against the RMSE target by target.  At step 0 it is exact: the restricted prior's
covariance is the error of its mean, the best estimate without scans.
Under line of sight (``[sensor] line_of_sight``) a scan's information is that of its
bearings where the truth is visible and 0 where it is hidden; what a miss says about
where the target hides is left out (the detection's likelihood jumps at a shadow's edge,
where the regularity the bound needs fails), so the bound is not strict there either.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..sensing import SIGMA_MAX_DEG, MeasurementModel
from ..targets import HORIZONTAL, Dynamics

__all__ = ["Bound", "jackknife_se", "pcrlb", "pcrlb_for_trials", "pcrlb_planned", "pcrlb_step"]  # docs/api.md

MAX_SIGMA = np.radians(SIGMA_MAX_DEG)  # pi / 8: the wrapped tail 2 Phi(-pi / sigma) of the noise is < 1e-15
_SQRT_2PI = np.sqrt(2.0 * np.pi)
POS = slice(0, 2)  # (x, y) in the state [x, y, z, vx, vy, vz]
HORIZONTAL_POS = slice(0, 2)  # (x, y) in [x, y, vx, vy]


# --------------------------------------------------------------------------- the IRF
def _q2_quadrature(lambda_u: float, p_detect: float, window: float, ds: float = 0.1, du: float = 0.04,
                   s_min: float = -25.0, extra: float = 0.0) -> float:
    """q2 by the trapezoid rule in ``s = log tau`` and u (module docstring).

    Parameters
    ----------
    lambda_u : false alarms per unit sigma, ``Lambda sigma / 2 pi`` (> 0);
    p_detect : in (0, 1]; window : half-width ``pi / sigma`` of the clutter window in u;
    ds, du, s_min, extra : grid steps, lower end in s and extra range (for accuracy checks).

    The s range starts where ``tau^2`` is below ``e^-50`` of its scale (``tau`` ~ 1, or
    ``2 / c`` when ``c`` is large) and ends where the integrand is below ``e^-40`` (its tail
    decays like ``e^-s`` for ``p_D = 1`` and like ``exp(-c e^s)`` otherwise); the u range
    covers ``tau phi(u) ~ 1`` at the largest tau with 6 sigma to spare.
    """
    c = lambda_u * (1.0 - p_detect) / p_detect
    s_min -= max(0.0, np.log(c)) if c > 0 else 0.0  # the integrand peaks near tau = 2 / c
    s_max = (40.0 if c == 0.0 else max(40.0, np.log(60.0 / c))) + extra
    u_max = np.sqrt(2.0 * s_max) + 6.0 + extra
    s = np.arange(s_min, s_max + ds / 2, ds)
    u = np.arange(0.0, u_max + du / 2, du)
    w = np.full(u.size, 2.0 * du)  # even integrands: twice the half line, trapezoid weights
    w[0] = du
    w_clutter = np.where(u <= window, w, 0.0)
    phi = np.exp(-0.5 * u * u) / _SQRT_2PI
    tau = np.exp(s)
    tphi = tau[:, None] * phi
    e = np.exp(-tphi)  # (S, U)
    g = np.exp(-lambda_u * (-np.expm1(-tphi) @ w_clutter))
    k = e @ (phi**2 * u**2 * w_clutter)
    lo = e @ (phi * w)
    m = e @ (phi**3 * u**2 * w)
    f = tau**2 * np.exp(-c * tau) * g * (lambda_u * k * (1.0 - p_detect + p_detect * lo) + p_detect * m)
    return float(ds * (f.sum() - 0.5 * (f[0] + f[-1])))


def _check_sensor(sigma: float, p_detect: float, clutter_rate: float) -> None:
    if not (np.isfinite(sigma) and 0.0 < sigma <= MAX_SIGMA):
        raise ValueError(f"sigma must be in (0, pi/8] rad (the bound takes the bearing noise as Gaussian "
                         f"on the line); got {sigma!r}")
    if not (np.isfinite(p_detect) and 0.0 <= p_detect <= 1.0):
        raise ValueError(f"p_detect must be in [0, 1]; got {p_detect!r}")
    if not (np.isfinite(clutter_rate) and clutter_rate >= 0.0):
        raise ValueError(f"clutter_rate must be finite and >= 0; got {clutter_rate!r}")


@lru_cache(maxsize=256)
def information_reduction_factor(sigma: float, p_detect: float, clutter_rate: float) -> float:
    """The IRF q2 in [0, 1] of one bearing scan with missed detections and clutter.

    ``J_Z = q2 h^T h / sigma^2`` is the Fisher information of a scan of Eq. (4); q2 is
    the expectation of the squared normalised score over detection, the false-alarm count
    and positions (module docstring).  Exact limits: ``q2 = p_D`` without clutter (so 1
    for ``p_D = 1``), 0 for ``p_D = 0``.  Otherwise trapezoid quadrature, absolute error
    about 1e-13 (a few ms; cached).

    Parameters
    ----------
    sigma : bearing noise std (rad), in (0, pi/8]; p_detect : p_D in [0, 1];
    clutter_rate : Lambda, mean false alarms per scan on the channel, >= 0.

    References
    ----------
    [Papaioannou2023] Eq. (4), (10); [Niu2001];
    [Hernandez2004, Sec. III-A].
    """
    _check_sensor(sigma, p_detect, clutter_rate)
    if clutter_rate == 0.0 or p_detect == 0.0:
        return float(p_detect)
    return _q2_quadrature(clutter_rate * sigma / (2.0 * np.pi), p_detect, np.pi / sigma)


# --------------------------------------------------------------------------- the recursion
def pcrlb_step(cov: np.ndarray, a: np.ndarray, q: np.ndarray, info: np.ndarray) -> np.ndarray:
    """One step ``J <- (Q + A J^-1 A^T)^-1 + E^T W E`` in covariance form (Woodbury).

    Parameters
    ----------
    cov : (M, n, n) bounds ``J_k^-1``; a, q : (n, n); info : (M, 2, 2) W on (x, y).

    Returns
    -------
    (M, n, n) ``J_{k+1}^-1``, symmetric.

    References
    ----------
    [Tichavsky1998, Eq. (21)].
    """
    pred = a @ cov @ a.T + q
    pe = pred[:, :, POS]  # P- E^T, (M, n, 2)
    # P- E^T W (I + E P- E^T W)^-1 E P- = P- E^T (I + W E P- E^T)^-1 W E P- (push-through)
    gain = np.linalg.solve(np.eye(2) + info @ pe[:, POS, :], info @ np.swapaxes(pe, 1, 2))  # (M, 2, n)
    out = pred - pe @ gain
    return 0.5 * (out + np.swapaxes(out, 1, 2))


def pcrlb(cov0: np.ndarray, a: np.ndarray, q: np.ndarray, info: np.ndarray) -> np.ndarray:
    """Bounds ``J_k^-1`` at steps k = 1..T from the prior ``J_0^-1 = cov0``.

    Parameters
    ----------
    cov0 : (M, n, n) prior covariances; a, q : (n, n) dynamics and process noise;
    info : (T, M, 2, 2) expected measurement information on (x, y) at steps 1..T.

    Returns
    -------
    (T, M, n, n).

    Raises
    ------
    FloatingPointError if a bound loses positivity on (x, y) or stops being finite.
    """
    out = np.empty((len(info), *cov0.shape))
    cov = cov0
    for k in range(len(info)):  # sequential by nature
        cov = out[k] = pcrlb_step(cov, a, q, info[k])
        var = np.diagonal(cov[:, POS, POS], axis1=1, axis2=2)
        if not (np.all(np.isfinite(cov)) and np.all(var >= 0.0)):
            raise FloatingPointError(f"step {k + 1}: the bound lost positivity on (x, y) (a sensor within "
                                     "rounding distance of a target?)")
    return out


# --------------------------------------------------------------------------- recorded trials
@dataclass(frozen=True, eq=False)
class Bound:
    """The PCRLB of a campaign's steps 1..T (rows as in a trial's ``err2``).

    Attributes
    ----------
    cov : (T, M, n, n) bounds on the error covariances; q2 : the sensor's IRF;
    trials : how many trials the expectation averaged.
    """

    cov: np.ndarray
    q2: float
    trials: int
    left_out: np.ndarray | None = None  # (trials, M, T) pos_per_target of the trials less each one

    @property
    def pos_per_target(self) -> np.ndarray:
        """(M, T) bound on the (x, y) RMSE, laid out like a summary's ``rmse_per_target``."""
        return np.sqrt(np.trace(self.cov[:, :, POS, POS], axis1=2, axis2=3)).T

    def standard_error(self, stat=lambda pos: pos.mean(axis=-2)):
        """The jackknife standard error of ``stat(pos_per_target)`` (default: the mean over
        targets, ``(T,)`` like :attr:`pos`) over the campaign's trials, or None with fewer
        than two trials or no leave-one-out bounds.  The bound's expectations are averages
        over the trials, so the bound itself is a Monte-Carlo estimate:
        ``se^2 = (n - 1) / n sum_i (stat_(i) - mean_i stat_(i))^2`` with ``stat_(i)`` from
        the trials less trial i [Efron1981]."""
        if self.left_out is None or self.trials < 2:
            return None
        return jackknife_se(np.asarray(stat(self.left_out)))

    @property
    def pos(self) -> np.ndarray:
        """(T,) mean over targets, comparable with a summary's ``rmse``."""
        return self.pos_per_target.mean(axis=0)


def _as_trials(x: np.ndarray, name: str, last: int) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    if x.ndim == 3:
        x = x[None]
    if x.ndim != 4 or x.shape[-1] < last:
        raise ValueError(f"{name} must be (trials, T, count, >={last}) or (T, count, >={last}); got shape {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{name} has non-finite entries")
    return x


def _check_model(cov0: np.ndarray, a: np.ndarray, q: np.ndarray, m: int) -> np.ndarray:
    n = a.shape[0]
    if a.shape != (n, n) or q.shape != (n, n) or n < 2:
        raise ValueError(f"A and Q must be square and alike; got {a.shape} and {q.shape}")
    cov0 = np.broadcast_to(np.asarray(cov0, float), (m, n, n)) if np.ndim(cov0) == 2 else np.asarray(cov0, float)
    if cov0.shape != (m, n, n):
        raise ValueError(f"cov0 must be ({n}, {n}) or ({m}, {n}, {n}); got {cov0.shape}")
    for name, mat in (("Q", q[None]), ("cov0", cov0)):
        if not np.allclose(mat, np.swapaxes(mat, 1, 2)) or np.linalg.eigvalsh(mat).min() < -1e-12 * np.abs(mat).max():
            raise ValueError(f"{name} must be symmetric positive semi-definite")
    return cov0


def pcrlb_for_trials(truth: np.ndarray, observers: np.ndarray, dynamics: Dynamics, cov0: np.ndarray,
                     sensor: MeasurementModel) -> Bound:
    """The closed-loop PCRLB of recorded trials, per step and target.

    Parameters
    ----------
    truth : (trials, T, M, 6) or (T, M, 6)
        True states at steps 1..T (``StepInfo.truth`` of ``Simulation.step``, not the
        reset's step 0).
    observers : (trials, T, S, 3) or (T, S, 3)
        Sensor positions at those steps (``StepInfo.observers``; S = 0, the no-sensor
        baseline, gives the prediction alone).
    dynamics : Dynamics
        Eq. (1)-(2) (``a`` and ``q`` are used).
    cov0 : (6, 6) or (M, 6, 6)
        The priors ``Sigma_0``.
    sensor : MeasurementModel
        The sensor of those observers (its IRF is computed once, cached).

    Returns
    -------
    Bound.  With one trial the bound is conditional on that trial's truth and path.

    References
    ----------
    [Papaioannou2023] Eq. (1)-(2), (4), (10); module docstring.
    """
    truth, observers = _as_trials(truth, "truth", 2), _as_trials(observers, "observers", 2)
    if truth.shape[:2] != observers.shape[:2]:
        raise ValueError(f"truth {truth.shape} and observers {observers.shape} differ in trials or steps")
    a, q = np.asarray(dynamics.a, float), np.asarray(dynamics.q, float)
    if truth.shape[-1] != a.shape[0]:
        raise ValueError(f"truth has {truth.shape[-1]} state components, the dynamics {a.shape[0]}")
    cov0 = _check_model(cov0, a, q, truth.shape[2])
    info = sensor.information(truth, observers, detect=_detect(sensor, truth, observers)).mean(axis=0)
    return Bound(cov=pcrlb(cov0, a, q, info), q2=sensor.information_factor(), trials=truth.shape[0])


def pcrlb_planned(sensitivity: np.ndarray, truth: np.ndarray, observers: np.ndarray, cov0: np.ndarray,
                  sensor: MeasurementModel) -> Bound:
    """The bound for a truth that is a deterministic function of its start (module
    docstring, "Which truth it bounds").

    Parameters
    ----------
    sensitivity : (trials, T, M, 4, 4) or (T, M, 4, 4)
        ``d x_k / d x_0`` on ``[x, y, vx, vy]`` at steps 1..T (``StepInfo.sensitivity``).
    truth : (trials, T, M, 6) or (T, M, 6)
        The true states.
    observers : (trials, T, S, 3) or (T, S, 3)
        The sensor positions.
    cov0 : (M, 6, 6)
        The priors ``Sigma_0`` (their ``[x, y, vx, vy]`` block is used).
    sensor : MeasurementModel
        The observers' sensor.

    Returns
    -------
    Bound with ``cov (T, M, 4, 4)`` on ``[x, y, vx, vy]``.

    References
    ----------
    [Papaioannou2023] Eq. (4), (10), Sec. VI-B (the noise-free truth); [VanTrees2007].
    """
    truth, observers = _as_trials(truth, "truth", 2), _as_trials(observers, "observers", 2)
    g = np.asarray(sensitivity, float)
    g = g[None] if g.ndim == 4 else g
    if g.shape != (*truth.shape[:3], 4, 4) or truth.shape[:2] != observers.shape[:2]:
        raise ValueError(f"sensitivity {g.shape}, truth {truth.shape} and observers {observers.shape} do not "
                         "match as (trials, T, M, 4, 4), (trials, T, M, 6), (trials, T, S, 3)")
    if not np.all(np.isfinite(g)):
        raise ValueError("sensitivity has non-finite entries")
    cov0 = np.asarray(cov0, float)[:, HORIZONTAL][:, :, HORIZONTAL]  # (M, 4, 4)
    w = sensor.information(truth, observers, detect=_detect(sensor, truth, observers))  # (trials, T, M, 2, 2)
    gp = g[..., HORIZONTAL_POS, :]  # (trials, T, M, 2, 4): d position / d x_0
    info = np.einsum("ntmia,ntmij,ntmjb->ntmab", gp, w, gp)  # G^T E^T W E G per trial, (trials, T, M, 4, 4)
    prior_info, n = np.linalg.inv(cov0), len(g)
    cov = _van_trees(prior_info, info.mean(axis=0), g.mean(axis=0))
    left_out = None
    if n > 1:  # the same bound from the trials less each one, LOO_CHUNK trials at a time
        sum_info, sum_g = info.sum(axis=0), g.sum(axis=0)
        left_out = np.concatenate([_pos(_van_trees(prior_info, (sum_info - info[i:i + LOO_CHUNK]) / (n - 1),
                                                   (sum_g - g[i:i + LOO_CHUNK]) / (n - 1)))
                                   for i in range(0, n, LOO_CHUNK)])
    return Bound(cov=cov, q2=sensor.information_factor(), trials=n, left_out=left_out)


def _detect(sensor: MeasurementModel, truth: np.ndarray, observers: np.ndarray) -> np.ndarray | None:
    """``(trials, T, M, S)``: 1 where sensor s sees target m along the truth, 0 where a
    building blocks it (line of sight), or None (every scan sees every target).  The
    information of a blocked scan is 0: its detection probability there is 0."""
    if not sensor.line_of_sight or observers.shape[-2] == 0:
        return None
    return sensor.visible(truth[..., :, None, :3], observers[..., None, :, :3]).astype(float)


def jackknife_se(left_out: np.ndarray) -> np.ndarray:
    """The jackknife standard error [Efron1981] of a statistic from its values on the n
    leave-one-out samples ``left_out (n, ...)``: ``sqrt((n - 1) / n sum_i (s_i - mean s)^2)``."""
    n = len(left_out)
    return np.sqrt((n - 1) / n * ((left_out - left_out.mean(axis=0)) ** 2).sum(axis=0))


LOO_CHUNK = 64  # leave-one-out bounds computed together (memory: 64 x T x M x 4 x 4 floats)


def _van_trees(prior_info: np.ndarray, info: np.ndarray, mean_g: np.ndarray) -> np.ndarray:
    """``E[G_k] J_k^-1 E[G_k]^T`` with ``J_k = Sigma_0^-1 + sum_{j <= k} E[G_j^T E^T W_j E G_j]``.

    Parameters
    ----------
    prior_info : (M, 4, 4) ``Sigma_0^-1``; info : (..., T, M, 4, 4) the expected scan
    information in ``x_0`` at each step; mean_g : (..., T, M, 4, 4) ``E[G_k]``.

    Returns
    -------
    (..., T, M, 4, 4), symmetric.
    """
    j = prior_info + np.cumsum(info, axis=-4)
    cov = mean_g @ np.linalg.solve(j, np.swapaxes(mean_g, -1, -2))
    return 0.5 * (cov + np.swapaxes(cov, -1, -2))


def _pos(cov: np.ndarray) -> np.ndarray:
    """(n, T, M, 4, 4) bounds -> (n, M, T) position RMSE bounds (as ``Bound.pos_per_target``)."""
    return np.swapaxes(np.sqrt(np.trace(cov[..., POS, POS], axis1=-2, axis2=-1)), -1, -2)
