"""One interface for the estimator library, with its inputs checked before any work.

Recursive filters (:class:`PLKF`, :class:`PLMMSE`)::

    f = PLMMSE(sigma=np.radians(1.0), x0=[...], P0=np.diag([...]), q=0.01, convention="north-cw")
    f.predict(dt=1.0); f.update(bearing, observer)      # None or NaN: a missed scan
    tracks, covs = f.filter(times, bearings, observers)  # (K, 4), (K, 4, 4)

Batch estimators (:class:`uavsim.estimators.nrpso.BatchTMA`) ``fit(times, bearings,
observers) -> self`` with ``x_``, ``cov_``, ``converged_`` and ``predict(times)``.

**Bearings** are in radians, in one of two conventions named by ``convention=``:
``"north-cw"`` (from +y, clockwise, ``atan2(dx, dy)``: the simulator's and [Oh2021]'s)
or ``"east-ccw"`` (from +x, anticlockwise, ``atan2(dy, dx)``: [Oliva2021]'s, [Li2022]'s,
[Huang2021]'s); each is converted once, here, to the convention of the code behind.
``units="deg"`` takes bearings and ``sigma`` in degrees on purpose; otherwise a bearing
outside [-2 pi, 2 pi] (compass bearings in [0, 2 pi) and noisy ones just past pi are
radians; they are wrapped) or a ``sigma`` above 0.5 rad is refused as probably degrees.  State
``[px, py, vx, vy]`` (m, m/s).
"""

from __future__ import annotations

import warnings

import numpy as np

from . import plkf, plmmse
from .constraints import _check

CONVENTIONS = ("north-cw", "east-ccw")
SIGMA_MAX_RAD = 0.5  # a bearing noise above this (29 deg) is far more likely degrees by mistake
SIGMA_HINT_RAD = 0.1  # above this (5.7 deg) in radians, a warning asks whether degrees were meant


class UnitsWarning(UserWarning):
    """A value that is valid but more likely given in the wrong unit."""


class NotFittedError(ValueError, AttributeError):
    """A result asked of an estimator before :meth:`fit` (scikit-learn's name and bases, so
    ``except NotFittedError`` and ``except ValueError`` both catch it)."""


class Params:
    """The scikit-learn estimator protocol for classes that keep their constructor's
    arguments as given (``self._keep(locals())`` first thing in ``__init__``):
    :meth:`get_params`, :meth:`set_params` (checked as the constructor checks), so
    ``sklearn.base.clone`` works, and :meth:`reset` (a recursive filter back at its prior)."""

    def _keep(self, args: dict) -> None:
        self._params = {k: v for k, v in args.items() if k not in ("self", "__class__")}

    def get_params(self, deep: bool = True) -> dict:
        """The constructor's arguments, as given."""
        return dict(self._params)

    def set_params(self, **params):
        """Change arguments (checked as the constructor checks them); returns self."""
        unknown = set(params) - set(self._params)
        if unknown:
            raise ValueError(f"unknown parameters {sorted(unknown)}; {type(self).__name__} takes "
                             f"{sorted(self._params)}")
        self.__init__(**{**self._params, **params})
        return self

    def reset(self):
        """Back to the state the constructor made (the prior, no fit); returns self."""
        self.__init__(**self._params)
        return self


def check_number(name: str, value, lo: float = -np.inf, hi: float = np.inf, integer: bool = False,
                 lo_open: bool = False, infinite: bool = False):
    """``value`` as a number in ``[lo, hi]`` (``(lo, hi]`` with ``lo_open``), an integer with
    ``integer``, finite unless ``infinite``; else a ValueError naming it."""
    ok = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)
    if ok and integer:
        ok = float(value).is_integer()
    if ok:
        v = float(value)
        ok = (np.isfinite(v) or infinite and np.isinf(v)) and (v > lo if lo_open else v >= lo) and v <= hi
    if not ok:
        kind = "an integer" if integer else "a number"
        where = f"{'(' if lo_open else '['}{lo:g}, {hi:g}]"
        raise ValueError(f"{name} must be {kind} in {where}; got {value!r}")
    return int(value) if integer else float(value)


class OriginWarning(UserWarning):
    """An estimate that depends on where the coordinate origin lies (UB- and VC-PLKF)."""


class ConvergenceWarning(UserWarning):
    """An iterative estimator stopped before converging in some runs (its ``converged_``
    says which); their estimates are not the optimum the method seeks."""


class SearchAreaWarning(UserWarning):
    """A search confined to an area ended on the area's boundary: the area, not the data,
    decided the estimate there (it acts as a prior); widen it."""


class DegenerateUpdateWarning(UserWarning):
    """Some updates were skipped (zero innovation variance, an undefined gain)."""


def convert(bearings, convention: str, to: str) -> np.ndarray:
    """Bearings (rad) from one convention to the other, wrapped to ``(-pi, pi]``
    (the two are mirror images about the 45-degree line: ``b' = pi/2 - b``)."""
    _check("convention", convention, CONVENTIONS)
    _check("to", to, CONVENTIONS)
    b = np.asarray(bearings, dtype=float)
    b = b if convention == to else np.pi / 2 - b
    return np.pi - np.mod(np.pi - b, 2 * np.pi)


def check_sigma(sigma, units: str = "rad", hint: bool = True) -> float:
    """A bearing noise std in radians (``units="deg"`` converts); with ``hint``, a
    :class:`UnitsWarning` for radians above :data:`SIGMA_HINT_RAD` (``sigma=0.5`` meant as
    degrees is 29 degrees in radians)."""
    _check("units", units, ("rad", "deg"))
    s = float(np.radians(sigma) if units == "deg" else sigma) if np.ndim(sigma) == 0 else np.nan
    if not np.isfinite(s) or s <= 0:
        raise ValueError(f"sigma must be a positive number of {units}; got {sigma!r}")
    if s > SIGMA_MAX_RAD:
        raise ValueError(f"sigma = {s:g} rad ({np.degrees(s):.3g} deg) is above {SIGMA_MAX_RAD} rad: probably "
                         "degrees; pass units='deg' to give degrees on purpose")
    if hint and units == "rad" and s > SIGMA_HINT_RAD:
        warnings.warn(f"sigma = {s:g} rad is {np.degrees(s):.3g} deg, a coarse bearing sensor: if you meant "
                      f"{s:g} deg, pass units='deg' (or np.radians(sigma))", UnitsWarning, stacklevel=3)
    return s


def check_bearings(bearings, convention: str, to: str, units: str = "rad", missing: bool = False,
                   shape: tuple | None = None) -> np.ndarray:
    """Bearings as the code behind wants them: radians, convention ``to``.  ``missing``:
    NaN marks a missed scan (recursive filters), else every value must be finite."""
    _check("units", units, ("rad", "deg"))
    b = np.asarray(bearings, dtype=float) if not isinstance(bearings, (str, bytes)) else None
    if b is None or b.ndim == 0 and shape is not None and len(shape) > 0:
        raise ValueError(f"bearings must be an array of numbers of shape {shape}; got {bearings!r}")
    if shape is not None and b.shape != shape:
        raise ValueError(f"bearings has shape {b.shape}; expected {shape}")
    if units == "deg":
        b = np.radians(b)
    bad = ~np.isfinite(b) if not missing else np.isinf(b)
    if bad.any():
        i = int(np.flatnonzero(bad.ravel())[0])
        raise ValueError(f"bearings[{i}] = {b.ravel()[i]} is not finite" +
                         ("" if missing else " (a recursive filter takes NaN as a missed scan)"))
    if np.any(np.abs(b[np.isfinite(b)]) > 2 * np.pi + 1e-9):
        i = int(np.argmax(np.abs(np.where(np.isfinite(b), b, 0)).ravel()))
        raise ValueError(f"bearings[{i}] = {b.ravel()[i]:g} is outside [-2 pi, 2 pi]: probably degrees; pass "
                         "units='deg' to give degrees on purpose (or np.radians(bearings))")
    return convert(b, convention, to)


def check_points(points, n: int, name: str) -> np.ndarray:
    """``(n, 2)`` finite positions (m); a single ``(2,)`` point is repeated."""
    p = np.asarray(points, dtype=float)
    if p.shape == (2,):
        p = np.broadcast_to(p, (n, 2))
    if p.shape != (n, 2):
        raise ValueError(f"{name} has shape {p.shape}; expected ({n}, 2) to match the bearings, or (2,)")
    if not np.all(np.isfinite(p)):
        raise ValueError(f"{name} holds non-finite values")
    return p


def check_times(times, n: int | None = None) -> np.ndarray:
    t = np.asarray(times, dtype=float)
    if t.ndim != 1 or (n is not None and len(t) != n):
        raise ValueError(f"times has shape {t.shape}; expected ({n if n is not None else 'K'},)")
    if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise ValueError("times must be finite and strictly increasing")
    return t


def check_state(x0, p0) -> tuple[np.ndarray, np.ndarray]:
    """A prior ``x0 (4,)`` and a symmetric positive definite ``P0 (4, 4)``."""
    x = np.asarray(x0, dtype=float)
    p = np.asarray(p0, dtype=float)
    if x.shape != (4,) or not np.all(np.isfinite(x)):
        raise ValueError(f"x0 must be 4 finite numbers [px, py, vx, vy]; got shape {x.shape}")
    if p.shape == (4,):
        p = np.diag(p)
    if p.shape != (4, 4) or not np.all(np.isfinite(p)):
        raise ValueError(f"P0 must be a finite 4x4 matrix (or 4 variances); got shape {p.shape}")
    if not np.allclose(p, p.T, rtol=1e-10, atol=0):
        raise ValueError("P0 is not symmetric")
    try:
        np.linalg.cholesky(p)
    except np.linalg.LinAlgError:
        raise ValueError("P0 is not positive definite") from None
    return x, p


class _Recursive(Params):
    """What :class:`PLKF` and :class:`PLMMSE` share: the state, predict / update, a
    whole sequence through :meth:`filter`, the count of degenerate updates, and
    :class:`Params` (``reset()`` puts the filter back at its prior: a second
    :meth:`filter` would otherwise continue from the first one's posterior)."""

    internal = "east-ccw"  # [Li2022], [Huang2021]: the code behind takes bearings from +x

    def __init__(self, x0, P0, q, dt: float, convention: str, units: str):  # noqa: N803 (the papers' P)
        _check("convention", convention, CONVENTIONS)
        _check("units", units, ("rad", "deg"))
        self.x, self.P = check_state(x0, P0)
        q_arr = np.asarray(q, dtype=float)
        if q_arr.shape not in ((), (2,)) or not np.all(np.isfinite(q_arr)) or np.any(q_arr < 0):
            raise ValueError(f"q must be a power spectral density >= 0 (m^2/s^3), one or two numbers; got {q!r}")
        if not (np.isfinite(dt) and dt > 0):
            raise ValueError(f"dt must be a positive number of seconds; got {dt!r}")
        self.q, self.dt, self.convention, self.units = q_arr, float(dt), convention, units
        self.degenerate, self.missed = 0, 0

    def predict(self, dt: float | None = None) -> None:
        """Move the estimate ``dt`` seconds (default the filter's; finite, >= 0) by the
        constant-velocity model."""
        dt = self.dt if dt is None else check_number("dt", dt, lo=0.0)
        f, q = plkf.cv_model(dt, self.q if self.q.ndim else float(self.q))
        x, p = plkf.predict(self.x[None], self.P[None], f, q)
        self.x, self.P = x[0], p[0]

    def update(self, bearing, observer) -> bool:
        """One scan: ``bearing`` (None or NaN: missed, nothing changes) seen from
        ``observer (2,)``.  Returns False where the update was degenerate (skipped; a
        :class:`DegenerateUpdateWarning` says so)."""
        if bearing is None or (np.ndim(bearing) == 0 and np.isnan(bearing)):
            self.missed += 1
            return True
        beta = check_bearings([bearing], self.convention, self.internal, self.units, shape=(1,))
        ok = self._apply(beta, check_points(observer, 1, "observer"))
        if not ok:
            warnings.warn(f"{type(self).__name__}: a degenerate update was skipped (an innovation variance that is "
                          "not positive: a prior wide against the range, or the observer on the estimate)",
                          DegenerateUpdateWarning, stacklevel=2)
        return ok

    def _apply(self, beta: np.ndarray, s: np.ndarray) -> bool:
        """An update with a checked bearing ``(1,)`` in the internal convention from ``s (1, 2)``."""
        x, p, ok = self._update(self.x[None], self.P[None], beta, s)
        self.x, self.P = x[0], p[0]
        self.degenerate += not ok[0]
        return bool(ok[0])

    def filter(self, times, bearings, observers) -> tuple[np.ndarray, np.ndarray]:
        """Every scan in turn: ``times (K,)`` s, ``bearings (K,)`` (NaN: missed),
        ``observers (K, 2)``; the prior is at ``times[0]``.  Returns ``tracks (K, 4)`` and
        ``covs (K, 4, 4)``, the estimate after each scan."""
        b = np.asarray(bearings, dtype=float)
        t = check_times(times, b.shape[0] if b.ndim == 1 else None)
        beta = check_bearings(b, self.convention, self.internal, self.units, missing=True, shape=(len(t),))
        s = check_points(observers, len(t), "observers")
        tracks, covs, before = np.empty((len(t), 4)), np.empty((len(t), 4, 4)), self.degenerate
        for k in range(len(t)):  # a recursion over scans: each step needs the last
            if k:
                self.predict(t[k] - t[k - 1])
            if np.isnan(beta[k]):
                self.missed += 1
            else:
                self._apply(beta[k:k + 1], s[k:k + 1])
            tracks[k], covs[k] = self.x, self.P
        if self.degenerate > before:
            warnings.warn(f"{type(self).__name__}: {self.degenerate - before} of {len(t)} updates were degenerate "
                          "and skipped", DegenerateUpdateWarning, stacklevel=2)
        return tracks, covs


class PLKF(_Recursive):
    """The pseudo-linear Kalman filter family of [Huang2021]: ``kind`` one of
    ``"plkf"``, ``"bc-plkf"``, ``"iv-plkf"``, ``"ub-plkf"``, ``"vc-plkf"`` (speed bounds
    ``v_min``, ``v_max``, m/s); ``sigma`` the bearing noise std; ``q`` the process
    noise's power spectral density (m^2/s^3, one or ``(q_x, q_y)``).

    UB- and VC-PLKF depend on where the coordinate origin lies: each is a bearing EKF
    whose bearings are weighted as if their noise were ``sigma / |alpha|``, ``alpha =
    -d / (u . s)`` (``d`` the predicted range, ``u`` the line of sight, ``s`` the
    observer's position; :mod:`uavsim.estimators.plkf`), right only where ``alpha`` is
    near 1: the origin near the target all along (a moving target leaves any fixed one).
    In [Huang2021]'s scenario 2 (100 runs) UB-PLKF's time-averaged error is 2221 m as
    given, 1068 m with the origin moved to (2000, 0) and 16443 m at (0, 5000) (VC: 2057,
    919, 12190 m); PLKF, BC and IV do not move.  :meth:`filter` raises an
    :class:`OriginWarning` when ``|alpha|`` lies outside
    [:data:`ALPHA_LOW`, :data:`ALPHA_HIGH`] at more than a quarter of the scans."""

    def __init__(self, sigma, x0, P0, q=0.0, dt: float = 1.0, kind: str = "plkf",  # noqa: N803
                 convention: str = "north-cw", units: str = "rad", v_min: float = 0.0, v_max: float = np.inf):
        self._keep(locals())
        _check("kind", kind, plkf.FILTERS)
        super().__init__(x0, P0, q, dt, convention, units)
        self.sigma, self.kind = check_sigma(sigma, units), kind
        v_min = check_number("v_min", v_min, lo=0.0)
        v_max = check_number("v_max", v_max, lo=v_min, infinite=True)
        self._options = {"v_min": v_min, "v_max": v_max} if kind == "vc-plkf" else {}
        self.alphas: list[float] = []  # UB / VC: the origin-dependent weight of each update

    def _update(self, x, p, beta, s):
        if self.kind in ("ub-plkf", "vc-plkf"):
            rel = x[0, :2] - s[0]
            d = float(np.hypot(*rel))
            m = float(rel @ s[0]) / d if d > 0 else 0.0
            self.alphas.append(-d / m if m else np.inf)
        return plkf.UPDATES[self.kind](x, p, beta, s, self.sigma, **self._options)

    def filter(self, times, bearings, observers) -> tuple[np.ndarray, np.ndarray]:
        start = len(self.alphas)
        out = super().filter(times, bearings, observers)
        a = np.abs(np.array(self.alphas[start:]))
        off = (a < ALPHA_LOW) | (a > ALPHA_HIGH)
        if len(a) and off.mean() > 0.25:
            warnings.warn(f"{self.kind}: its estimate depends on the coordinate origin: the bearing weight |alpha| = "
                          f"|d / (u . s)| was outside [{ALPHA_LOW}, {ALPHA_HIGH}] at {off.mean():.0%} of the updates "
                          f"(median {np.median(a):.3g}; 1 is right only with the origin near the target all along): "
                          "moving the origin changes the track (see PLKF's docstring); kind='iv-plkf' does not depend "
                          "on it",
                          OriginWarning, stacklevel=2)
        return out


ALPHA_LOW, ALPHA_HIGH = 0.5, 2.0  # UB / VC bearing weights outside this range are the origin's doing


class PLMMSE(_Recursive):
    """PL-MMSE of [Li2022] (``kind="pl-mmse"``) or its baselines (``"plkf"``,
    ``"bc-plkf"``, ``"ivkf"``) under Gaussian-mixture bearing noise: ``noise`` a
    :class:`uavsim.estimators.plmmse.GaussianMixture` (rad) or a number, the std of
    Gaussian noise.  ``constraint(x (R, 4), P (R, 4, 4)) -> (x~, ok)`` (from
    :mod:`uavsim.estimators.constraints`): ``estimate`` is the constrained estimate after
    each update; the filter itself runs unconstrained ([Li2022] Tables 2-3)."""

    def __init__(self, noise, x0, P0, q=0.0, dt: float = 1.0, kind: str = "pl-mmse",  # noqa: N803
                 convention: str = "north-cw", units: str = "rad", constraint=None):
        self._keep(locals())
        _check("kind", kind, plmmse.FILTERS)
        super().__init__(x0, P0, q, dt, convention, units)
        if not isinstance(noise, plmmse.GaussianMixture):
            noise = plmmse.GaussianMixture((1.0,), (check_sigma(noise, units) ** 2,))
        elif noise.covs.shape[1:] != (1, 1):
            raise ValueError(f"noise must be a scalar (bearing) mixture; got components of {noise.covs.shape[1:]}")
        else:
            for var in noise.covs[:, 0, 0]:
                check_sigma(np.sqrt(var), hint=False)  # a mixture is given in radians; outliers may be wide
        self.noise, self.kind, self.constraint = noise, kind, constraint
        self.estimate = self.x

    def _update(self, x, p, beta, s):
        x, p, ok = plmmse.UPDATES[self.kind](x, p, beta, s, self.noise)
        if self.constraint is not None:
            est, fine = self.constraint(x, p)
            self.estimate = est[0]
            ok = ok & fine
        else:
            self.estimate = x[0]
        return x, p, ok


class ConstrainedMLE(Params):
    """The intelligence-aware batch MLE of [Oliva2021] with the batch face of
    :class:`uavsim.estimators.nrpso.BatchTMA`: a polynomial track of ``order`` (1:
    constant velocity, ``x_ = [px, py, vx, vy]``; 2: constant acceleration, ``[.., ax,
    ay]``) at the first scan's time, fitted to the bearings by Levenberg-Marquardt and,
    with intelligence, by SLSQP subject to "inside every disc of ``inside``, outside every
    disc of ``outside``" at every scan time ([Oliva2021] Eq. 14).  ``cov_`` is the
    unconstrained CRLB at the estimate ([Oliva2021] Eq. 16).  Bearings default to
    ``"north-cw"`` like every estimator here ([Oliva2021] measures from east,
    anticlockwise: pass ``convention="east-ccw"`` for its data)."""

    def __init__(self, sigma, inside=(), outside=(), order: int = 2, convention: str = "north-cw",
                 units: str = "rad"):
        self._keep(locals())
        from .intelligence import Disc

        _check("convention", convention, CONVENTIONS)
        if order not in (1, 2):
            raise ValueError(f"order must be 1 (constant velocity) or 2 (constant acceleration); got {order!r}")
        for d in (*inside, *outside):
            if not isinstance(d, Disc):
                raise ValueError(f"inside and outside hold Disc(centre, radius) sets; got {d!r}")
        self._sigma = check_sigma(sigma, units)
        self.sigma, self.inside, self.outside, self.order = sigma, tuple(inside), tuple(outside), order
        self.convention, self.units = convention, units

    def fit(self, times, bearings, observers) -> ConstrainedMLE:
        """``times (K,)`` s; ``bearings (K,)`` or ``(R, K)`` (R independent runs, solved as
        one batch by Levenberg-Marquardt and one SLSQP problem a run with intelligence);
        ``observers (K, 2)`` or ``(R, K, 2)`` m.  The attributes gain a leading ``R`` axis
        after a batch, as :class:`uavsim.estimators.nrpso.BatchTMA`'s do."""
        from .batch import fisher, polynomial_basis, prepare, spd_inverse
        from .intelligence import Intelligence, TrackConstraints, pseudo_linear, solve

        b = np.asarray(bearings, dtype=float)
        n = 2 * (self.order + 1)
        if b.ndim not in (1, 2) or b.shape[-1] < n:
            raise ValueError(f"bearings has shape {b.shape}; expected (K,) or (R, K) with K >= {n} scans for the "
                             f"{n} unknowns")
        t = check_times(times, b.shape[-1])
        b = check_bearings(b, self.convention, "east-ccw", self.units, shape=b.shape)
        obs = np.asarray(observers, dtype=float)
        if obs.shape not in ((b.shape[-1], 2), (*b.shape, 2)) or not np.all(np.isfinite(obs)):
            raise ValueError(f"observers has shape {obs.shape}; expected ({b.shape[-1]}, 2) or {(*b.shape, 2)} "
                             "of finite numbers")
        phi = polynomial_basis(t, self.order)
        data = prepare(phi, obs, b, self._sigma)
        res = solve(data, pseudo_linear(data))
        if self.inside or self.outside:
            tc = TrackConstraints(Intelligence(self.inside, self.outside), phi)
            res = solve(data, res.theta, tc)
        x = res.theta[:, 0]
        cov, ok = spd_inverse(fisher(data, x[:, None])[:, 0])  # the Fisher matrix does not use the bearings
        self.t0_, self.x_ = float(t[0]), x
        self.cov_ = np.where(ok[:, None, None], cov, np.nan)
        self.converged_, self.violation_ = res.converged[:, 0] & ok, res.violation[:, 0]
        if b.ndim == 1:
            for name in ("x_", "cov_", "converged_", "violation_"):
                setattr(self, name, getattr(self, name)[0])
            self.converged_, self.violation_ = bool(self.converged_), float(self.violation_)
        return self

    def predict(self, times, return_cov: bool = False):
        """States ``[px, py, vx, vy]`` ``(K, 4)`` of the fitted track at ``times`` (``(R, K,
        4)`` after a batch fit; the acceleration of order 2 is ``x_[4:]``), and with
        ``return_cov`` their covariances ``(K, 4, 4)``: ``cov_`` carried along the track (as
        :meth:`uavsim.estimators.nrpso.BatchTMA.predict`)."""
        from .batch import polynomial_basis

        if not hasattr(self, "x_"):
            raise NotFittedError("this ConstrainedMLE is not fitted: call fit before predict")
        t = prediction_times(times)
        pos = polynomial_basis(t, self.order, t_ref=self.t0_)  # (K, 2, n)
        vel = np.pad(polynomial_basis(t, self.order - 1, t_ref=self.t0_), ((0, 0), (0, 0), (2, 0)))
        return track(np.concatenate([pos, vel], axis=1), self.x_, self.cov_, return_cov)


def prediction_times(times) -> np.ndarray:
    """``times`` as a non-empty 1-D float array of finite seconds (any order), for ``predict``."""
    t = np.asarray(times, dtype=float)
    if t.ndim != 1 or len(t) == 0 or not np.isfinite(t).all():
        raise ValueError(f"times must be a non-empty 1-D array of finite seconds; got shape {t.shape}")
    return t


def track(m, x, cov, return_cov: bool):
    """States ``m x`` at K times from a batch fit's parameters ``x (n,)`` or ``(R, n)``, and
    with ``return_cov`` their covariances ``m cov m^T``: ``m (K, 4, n)`` maps the
    parameters to ``[px, py, vx, vy]`` at each time (linear, so the covariance is exact
    for the parameters' ``cov``)."""
    x, cov = np.asarray(x), np.asarray(cov)
    states = np.einsum("kin,...n->...ki", m, x)
    if not return_cov:
        return states
    return states, np.einsum("kin,...nm,kjm->...kij", m, cov, m)
