"""The measurement model: a bearing sensor with missed detections, Poisson clutter and
(optionally) line of sight, as one object every consumer takes.

[Papaioannou2023] Eq. (4) and Sec. III-C: on target j's channel the UAV at s
receives, each step,

* with probability ``p_D`` one target bearing ``phi = l(x, s) + w``, ``w ~ N(0, sigma^2)``,
  ``l(x, s) = atan2(x_x - s_x, x_y - s_y)`` (from north, clockwise);
* ``Poisson(Lambda)`` false alarms, uniform on ``(-pi, pi]``.

Every bearing is wrapped to ``(-pi, pi]``.  A scan is stored padded: ``(M, K)`` arrays
with a ``valid`` mask, K the largest set size of that scan.

:class:`BearingModel` is the sensor's one room (after Stone Soup's measurement models):
the expected bearing (:meth:`~BearingModel.expected`), its gradient
(:meth:`~BearingModel.jacobian`), the scan likelihood with clutter and ``p_D`` (Eq. 10,
:meth:`~BearingModel.log_likelihood`), drawing a scan (:meth:`~BearingModel.draw`), the
information factor and the Fisher information the bound and the decision use
(:meth:`~BearingModel.information_factor`, :meth:`~BearingModel.information`), and the
detection probability at a position (:meth:`~BearingModel.detection`: ``p_D``, or 0 where
a building blocks the line of sight).  The particle filter, the Gaussian beliefs, the
traces of Eq. (12), the lookahead, the fixed sensors and the PCRLB all take the object;
none re-derives the model.  A new sensor is one class with these methods
(:class:`MeasurementModel` gives the ones that follow from the others; the tests fly a
range-bearing model through the filter, the traces and the bound).

**Line of sight** (``[sensor] line_of_sight``, off for the paper's missions, which have
none; on by default for imported towns): the target is detected only when the straight
segment from the sensor to it is clear of every obstacle (3-D, closed prisms,
:meth:`uavsim.world.World.segment_blocked`); its detection probability is ``p_D`` there
and 0 behind a building.  Clutter is unchanged.  The likelihood of a scan then uses each
particle's own detection probability, so a scan without the target's bearing moves
the belief towards the places the sensor cannot see.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .declare import degrees, setting

__all__ = [  # the public interface (docs/api.md renders each)
    "BearingModel", "MeasurementModel", "Scan", "bearing", "bearing_gradients", "log_likelihood", "observe",
    "scan_loglik", "uniform_loglik", "wrap_angle"
]


def wrap_angle(angle: np.ndarray) -> np.ndarray:
    """Wrap angles to ``(-pi, pi]`` (``-pi`` maps to ``+pi``)."""
    return np.pi - np.mod(np.pi - np.asarray(angle, dtype=float), 2.0 * np.pi)


def bearing(target: np.ndarray, sensor: np.ndarray) -> np.ndarray:
    """Noise-free bearing ``l(x, s)`` of Eq. (4), from +y (north) clockwise.

    Parameters
    ----------
    target, sensor : (..., >=2) positions; only x and y are used; broadcast together.

    Returns
    -------
    (...,) angle in ``(-pi, pi]``.

    References
    ----------
    [Papaioannou2023] Eq. (4), ``tan^-1((x_x - s_x) / (x_y - s_y))`` taken as the
    four-quadrant ``atan2(dx, dy)``.
    """
    t, s = np.asarray(target), np.asarray(sensor)
    return wrap_angle(np.arctan2(t[..., 0] - s[..., 0], t[..., 1] - s[..., 1]))


# The largest bearing noise the models support: the PCRLB takes the noise as Gaussian on
# the line, whose wrapped tail 2 Phi(-pi / sigma) is below 1e-15 up to pi / 8.
SIGMA_MAX_DEG = 22.5


class MeasurementModel:
    """What every sensor model gives its consumers, and the parts that follow from the rest.

    A model defines ``expected(targets, observers)``, ``jacobian(targets, observers,
    min_range)`` ``(..., M, S, d, 2)`` (d the measurement's size, on the horizontal
    position), ``noise_cov`` ``(d, d)``, ``information_factor()``, ``detection(points,
    observer)``, ``draw(rng, targets, observer)``, ``log_likelihood(scan, particles,
    observer)`` and ``uniform_loglik(valid)`` (the scan's likelihood for a target anywhere,
    the yardstick of a lost track).  From those this class gives the Fisher information of
    a scan (the PCRLB and the lookahead), the pseudo-measurement log-likelihood of Eq. (12)
    (the particle traces) and the linearised traces (Gaussian beliefs).
    """

    line_of_sight = False

    def information(self, targets: np.ndarray, observers: np.ndarray, min_range: float = 0.0,
                     detect: np.ndarray | None = None) -> np.ndarray:
        """``J_Z = q2 sum_s H_s^T R^-1 H_s`` on (x, y) of one scan by every sensor.

        Parameters
        ----------
        targets : (..., M, >=2)
            True positions.
        observers : (..., S, >=2)
            Sensor positions (the leading dimensions broadcast with the targets').
        min_range : float
            The range is floored there (m).
        detect : (..., M, S) or None
            The share of the information each sensor delivers, in [0, 1] (0 where the
            line of sight is blocked); None: all of it.

        Returns
        -------
        (..., M, 2, 2).
        """
        h = self.jacobian(targets, observers, min_range)  # (..., M, S, d, 2)
        rinv = np.linalg.inv(self.noise_cov)
        scale = self.information_factor() if detect is None else self.information_factor() * detect[..., None, None]
        per = np.einsum("...di,de,...ej->...ij", h, rinv, h)  # (..., M, S, 2, 2)
        return (per * scale).sum(axis=-3)

    def pseudo_loglik(self, candidates: np.ndarray, particles: np.ndarray, mean: np.ndarray) -> np.ndarray:
        """``log N(h(mu_j, s); h(x_i, s), R)`` up to a constant, ``(M, C, N)``: Eq. (12)'s
        noise-free measurement from the predicted mean ``mean (M, >=2)``, for candidates
        ``(C, >=2)`` and particles ``(M, N, >=2)``."""
        z = self.expected(mean[:, None, :], candidates[None, :, :])  # (M, C[, d])
        zi = self.expected(particles[:, None, :, :], candidates[None, :, None, :])  # (M, C, N[, d])
        r = self.residual(z[:, :, None], zi)
        r = r.reshape(*r.shape[:3], -1)
        return -0.5 * np.einsum("...d,de,...e->...", r, np.linalg.inv(self.noise_cov), r)

    def residual(self, z: np.ndarray, expected: np.ndarray) -> np.ndarray:
        """``z - expected``, wrapped where the model has angles (this default: none)."""
        return z - expected


@dataclass(frozen=True)
class BearingModel(MeasurementModel):
    """The bearing sensor of Eq. (4) and Sec. III-C, the same for every channel.

    Attributes
    ----------
    sigma : bearing noise std (rad); p_detect : p_D; clutter_rate : Lambda (per scan, per
    channel); line_of_sight : detections need a clear line of sight (module docstring).
    world : the obstacles that block it (set by the mission reader when
    ``line_of_sight`` is on; not a setting); None: nothing blocks it.
    """

    sigma: float = setting("sigma_deg", 1.0, unit="deg", lo=0.001, hi=SIGMA_MAX_DEG, **degrees,
                           doc="bearing noise standard deviation sigma (Eq. 4); at most 22.5, where the "
                               "wrapped tail of the noise (taken as Gaussian on the line by the bound) is below 1e-15")
    p_detect: float = setting("p_detect", 0.95, lo=0, hi=1, doc="p_D, that a scan holds the target's bearing")
    clutter_rate: float = setting("clutter_rate", 1.0, unit="per scan", lo=0, hi=100,
                                  doc="Lambda, mean false alarms per scan on each target's channel (Poisson)")
    line_of_sight: bool = setting("line_of_sight", False, kind="boolean",
                                  doc="a target is detected only when the segment sensor-target is clear of every "
                                      "obstacle (p_D there, 0 behind a building); off in the paper's missions, on "
                                      "in those uavsim world import writes")
    world: object = field(default=None, compare=False, repr=False)

    @property
    def noise_cov(self) -> np.ndarray:
        """``(1, 1)`` ``R = sigma^2``."""
        return np.array([[self.sigma**2]])

    def expected(self, targets: np.ndarray, observers: np.ndarray) -> np.ndarray:
        """Noise-free bearings ``l(x, s)`` (:func:`bearing`), ``(...)``."""
        return bearing(targets, observers)

    def residual(self, z: np.ndarray, expected: np.ndarray) -> np.ndarray:
        return wrap_angle(z - expected)

    def jacobian(self, targets: np.ndarray, observers: np.ndarray, min_range: float = 0.0) -> np.ndarray:
        """``d l / d(x, y)`` ``(..., M, S, 1, 2)`` (:func:`bearing_gradients`)."""
        return bearing_gradients(targets, observers, min_range)[..., None, :]

    def information_factor(self) -> float:
        """The IRF q2 of one scan with missed detections and clutter
        (:func:`uavsim.bounds.pcrlb.information_reduction_factor`, cached)."""
        from .bounds.pcrlb import information_reduction_factor  # numpy only; the IRF's derivation lives there

        return information_reduction_factor(self.sigma, self.p_detect, self.clutter_rate)

    def visible(self, points: np.ndarray, observers: np.ndarray) -> np.ndarray:
        """``(...)`` bool: the segment ``observers -> points`` (broadcast, ``(..., 3)``) is
        clear of every obstacle (always True without line of sight).  Where every observer
        sees every point (the UAV's candidate moves and the targets' particles) the segments
        are tested as fans (:meth:`~uavsim.world.World.fans_blocked`); otherwise points of
        three or more dimensions (targets first, ``(M, ..., 3)``) are taken one target at a
        time, so that the obstacle test's broad phase keeps to the buildings near each
        target's cloud."""
        points, observers = np.asarray(points, dtype=float), np.asarray(observers, dtype=float)
        shape = np.broadcast_shapes(points.shape[:-1], observers.shape[:-1])
        if not self.line_of_sight or self.world is None or self.world.n_obstacles == 0:
            return np.ones(shape, bool)
        n_obs, n_pts = observers[..., 0].size, points[..., 0].size
        if n_obs > 1 and n_obs * n_pts == np.prod(shape):  # every observer sees every point: a fan from each
            blocked = self.world.fans_blocked(observers.reshape(-1, 3), points.reshape(-1, 3))  # (n_obs, n_pts)
            return ~blocked[np.broadcast_to(np.arange(n_obs).reshape(observers.shape[:-1]), shape),
                            np.broadcast_to(np.arange(n_pts).reshape(points.shape[:-1]), shape)]
        if points.ndim < 3 or points.ndim < observers.ndim or points.shape[0] == 1:
            return ~self.world.segment_blocked(observers, points)
        same = observers.ndim == points.ndim  # then observers' first axis is the targets' too (or 1)
        return np.stack([~self.world.segment_blocked(observers[min(j, len(observers) - 1)] if same else observers, p)
                         for j, p in enumerate(points)])

    def detection(self, points: np.ndarray, observers: np.ndarray) -> np.ndarray | float:
        """Detection probability at ``points (..., 3)`` seen from ``observers (..., 3)``:
        ``p_D``, or 0 where the line of sight is blocked; the scalar ``p_D`` without
        line of sight."""
        if not self.line_of_sight:
            return self.p_detect
        return np.where(self.visible(points, observers), self.p_detect, 0.0)

    def draw(self, rng: np.random.Generator, targets: np.ndarray, observer: np.ndarray) -> Scan:
        """One scan of Eq. (4) with missed detections and clutter (:func:`observe`)."""
        return observe(rng, self, targets, observer)

    def log_likelihood(self, scan: Scan, particles: np.ndarray, observer: np.ndarray) -> np.ndarray:
        """Eq. (10) for every particle ``(M, N, >=3)`` and one scan taken at ``observer (3,)``
        (:func:`scan_loglik`), with each particle's own ``p_D`` under line of sight."""
        return scan_loglik(scan, particles, observer, self)

    def uniform_loglik(self, valid: np.ndarray) -> np.ndarray:
        """:func:`uniform_loglik`."""
        return uniform_loglik(valid, self)


def bearing_gradients(targets: np.ndarray, observers: np.ndarray, min_range: float = 0.0) -> np.ndarray:
    """``d l / d(x, y)`` of the [Papaioannou2023] bearing ``atan2(dx, dy)``: ``(dy, -dx) / r^2``.

    Parameters
    ----------
    targets : (..., M, >=2)
        True positions.
    observers : (..., S, >=2)
        Sensor positions (the leading dimensions broadcast).
    min_range : float
        The range is floored there (m); 0: no floor.

    Returns
    -------
    (..., M, S, 2).

    Raises
    ------
    ValueError when a sensor is at a target's horizontal position (bearing undefined).

    References
    ----------
    [Papaioannou2023] Eq. (4).
    """
    d = targets[..., :, None, :2] - observers[..., None, :, :2]  # (..., M, S, 2)
    r2 = np.maximum((d**2).sum(-1, keepdims=True), min_range**2)
    if np.any(r2 == 0.0):
        raise ValueError("a sensor is exactly above a target (zero horizontal range): the bearing and its "
                         "information are undefined there")
    return np.stack([d[..., 1], -d[..., 0]], -1) / r2


@dataclass(frozen=True, eq=False)
class Scan:
    """One scan of M channels, padded to K entries.

    Attributes
    ----------
    bearings : (M, K) rad, 0 where not valid (a model with d > 1 values per measurement:
    ``(M, K, d)``).
    valid : (M, K) bool, entry is a received measurement.
    from_target : (M, K) bool, entry is the target's own bearing (truth, for recording).
    blocked : (M,) bool, the target's line of sight was blocked (truth, for recording), or None.
    """

    bearings: np.ndarray
    valid: np.ndarray
    from_target: np.ndarray
    blocked: np.ndarray | None = None

    @property
    def counts(self) -> np.ndarray:
        """(M,) number of measurements ``n^j`` per channel."""
        return self.valid.sum(axis=1)


def observe(rng: np.random.Generator, sensor: BearingModel, targets: np.ndarray, observer: np.ndarray) -> Scan:
    """Draw one scan of Eq. (4) with missed detections and clutter.

    Parameters
    ----------
    rng : the only source of randomness.
    targets : (M, >=2) true target positions (``(M, 3)`` under line of sight);
    observer : (>=2,) sensor position.

    Returns
    -------
    Scan with the target bearing (if detected) in column 0 of its channel, then clutter.
    The draws are the same with and without line of sight (a blocked target's detection
    draw is made and discarded), so both see the same noise and clutter.
    """
    m = targets.shape[0]
    detected = rng.random(m) < sensor.p_detect
    blocked = None
    if sensor.line_of_sight:
        blocked = ~sensor.visible(targets[:, :3], np.asarray(observer)[:3])
        detected &= ~blocked
    noisy = bearing(targets, observer) + sensor.sigma * rng.standard_normal(m)
    n_clutter = rng.poisson(sensor.clutter_rate, size=m)
    clutter = rng.uniform(-np.pi, np.pi, size=int(n_clutter.sum()))

    det = detected.astype(int)
    k = int((det + n_clutter).max(initial=0))
    col = np.arange(k)
    valid = col < (det + n_clutter)[:, None]
    from_target = (col == 0) & detected[:, None]
    bearings = np.zeros((m, k))
    bearings[from_target] = noisy[detected]
    bearings[valid & ~from_target] = clutter  # row-major fill keeps the draw order fixed
    return Scan(bearings=wrap_angle(bearings), valid=valid, from_target=from_target, blocked=blocked)


# --------------------------------------------------------------------------- Eq. (10)
LOG_2PI = math.log(2.0 * np.pi)
EXP_FLOOR = -700.0  # exp(-700) = 1e-304: nothing next to a sum >= 1
SHIFT_GAP = 600.0  # a sum >= e^-600 leaves e^-700 at 1e-43 of it


def log_likelihood(bearings: np.ndarray, valid: np.ndarray, expected: np.ndarray, sensor: BearingModel) -> np.ndarray:
    """``log g(Phi | x)`` of Eq. (10), closed form for uniform clutter (module docstring).

    Parameters
    ----------
    bearings, valid : (M, K) one scan's padded measurement sets.
    expected : (M, N) noise-free bearings ``l(x, s)`` of the particles (any angle; wrapped here).

    Returns
    -------
    (M, N) log-likelihoods (``-inf`` where a particle cannot explain the set).

    References
    ----------
    [Papaioannou2023] Eq. (10).
    """
    return _log_likelihood(wrap_angle(bearings), valid, wrap_angle(expected), sensor)


def _log_likelihood(bearings: np.ndarray, valid: np.ndarray, expected: np.ndarray, sensor: BearingModel) -> np.ndarray:
    """:func:`log_likelihood` for bearings and ``expected`` already in ``[-pi, pi]``.

    Each target's set has ``1 + n`` association hypotheses: "all clutter", with log
    weight ``log_miss`` (:func:`_hypothesis_logs`), and "column k is the target", with
    ``log_det - log(sigma sqrt(2 pi)) - r_k^2 / (2 sigma^2)``.  Their log-sum-exp is taken
    with the hypotheses on a leading axis ``(K, M, N)`` (a reduction over a short last axis
    is several times slower), in one of two ways:

    * :func:`_shared_shift` when ``p_D < 1`` and ``Lambda > 0`` and the detection and
      clutter weights are within ``e^SHIFT_GAP`` of each other (the paper's sensors): one
      shift for every particle;
    * :func:`_particle_shift` otherwise (``p_D = 1`` or no clutter, where a particle's
      only finite hypotheses may all be tiny): each particle shifted by its own largest.
    """
    lam, pd, sig = sensor.clutter_rate, sensor.p_detect, sensor.sigma
    n = np.count_nonzero(valid, axis=1)  # (M,) set sizes
    terms = _residual_exponents(bearings, expected, sig)
    if 0 < pd < 1 and lam > 0:
        # log weight of "column k is the target" over "all clutter", the same for every n >= 1
        log_clutter = math.log(lam) - LOG_2PI
        ratio = math.log(pd) - math.log1p(-pd) - log_clutter - math.log(sig) - 0.5 * LOG_2PI
        if abs(ratio) < SHIFT_GAP:
            out = _shared_shift(terms, valid, ratio)
            # + log_miss = log (1 - p_D) (L / 2pi)^n, + ratio where n > 0, - Lambda
            base = math.log1p(-pd) - lam
            out += np.where(n > 0, n * log_clutter + (ratio + base), base)[:, None]
            return out
    log_miss, log_det = _hypothesis_logs(n, lam, pd)  # (M,) each
    const = np.where(valid.T, log_det - math.log(sig) - 0.5 * LOG_2PI, -np.inf)  # (K, M)
    return _particle_shift(terms, const, log_miss) - lam


def _residual_exponents(bearings: np.ndarray, expected: np.ndarray, sig: float) -> np.ndarray:
    """``-r^2 / (2 sigma^2)`` (K, M, N) for the wrapped residuals of ``bearings (M, K)``
    and ``expected (M, N)``, both in ``[-pi, pi]``: then ``d = l - phi`` lies in
    ``[-2 pi, 2 pi]`` and the wrapped residual has ``|r| = pi - |pi - |d||`` (no ``mod``)."""
    terms = np.subtract(expected, bearings.T[:, :, None])  # (K, M, N) d = l - phi
    np.abs(terms, out=terms)
    np.subtract(np.pi, terms, out=terms)
    np.abs(terms, out=terms)
    np.subtract(np.pi, terms, out=terms)  # |r|
    np.square(terms, out=terms)
    terms *= -0.5 / sig**2
    return terms


def _shared_shift(terms: np.ndarray, valid: np.ndarray, ratio: float) -> np.ndarray:
    """``log(e^-ratio [n > 0] + sum_k exp(terms_k))`` (M, N) from ``terms (K, M, N)``
    (overwritten), for ``|ratio| < SHIFT_GAP``; a target with ``n = 0`` gets 0.

    Eq. (10) divided by its "all clutter" weight is ``1 + sum_k e^(ratio - r_k^2 /
    2 sigma^2)`` = ``e^ratio (e^-ratio + sum_k ...)``: the first term bounds the sum below
    by ``e^-SHIFT_GAP``, so exponents under ``EXP_FLOOR`` are raised to it (an ``e^-700``
    and a 0 then give the same double, and ``exp`` of an underflowing argument runs
    several times slower) and nothing overflows."""
    padded = valid.shape[1] == 0 or not valid.all()
    if padded:
        terms[~valid.T] = -np.inf
    np.maximum(terms, EXP_FLOOR, out=terms)
    total = np.exp(terms, out=terms).sum(axis=0)
    total += math.exp(-ratio)
    out = np.log(total, out=total)
    if padded:
        out[~valid.any(axis=1)] = 0.0
    return out


def _particle_shift(terms: np.ndarray, const: np.ndarray, log_miss: np.ndarray) -> np.ndarray:
    """``log(e^log_miss + sum_k e^(const_k + terms_k))`` (M, N), each particle shifted by
    its largest hypothesis, so its sum is at least 1 (``-inf`` where no hypothesis can
    explain the set).  ``terms (K, M, N)`` is overwritten; ``const (K, M)``, ``-inf`` for
    padding; ``log_miss (M,)``."""
    dead = np.isneginf(log_miss) & np.isneginf(const).all(axis=0)  # (M,) nothing explains the set
    terms += const[:, :, None]
    top = np.maximum(terms.max(axis=0, initial=-np.inf), log_miss[:, None])  # (M, N)
    top[dead] = 0.0
    terms -= top
    np.maximum(terms, EXP_FLOOR, out=terms)
    total = np.exp(terms, out=terms).sum(axis=0)
    total += np.exp(np.maximum(log_miss[:, None] - top, EXP_FLOOR))
    out = np.log(total, out=total)
    out += top
    out[dead] = -np.inf
    return out


def _hypothesis_logs(n: np.ndarray, lam: float, pd: float) -> tuple[np.ndarray, np.ndarray]:
    """Eq. (10) with the factorials cancelled, for set sizes ``n (M,)``: the log weights of
    "all n are clutter", ``log (1 - p_D) (L / 2pi)^n``, and of "one given measurement is
    the target", ``log p_D (L / 2pi)^(n-1)`` (``-inf`` for ``n = 0``)."""
    log_pd = math.log(pd) if pd > 0 else -np.inf
    log_miss_p = math.log1p(-pd) if pd < 1 else -np.inf

    def clutter(k):  # log (L / 2pi)^k, with (0 / 2pi)^0 = 1
        return k * (math.log(lam) - LOG_2PI) if lam > 0 else np.where(k == 0, 0.0, -np.inf)

    log_miss = log_miss_p + clutter(n)
    log_det = np.where(n >= 1, log_pd + clutter(np.maximum(n - 1, 0)), -np.inf)
    return log_miss, log_det


def uniform_loglik(valid: np.ndarray, sensor: BearingModel) -> np.ndarray:
    """``log g(Phi)`` of Eq. (10) for a target whose bearing is uniform on the circle:
    ``(M,)`` from one scan's ``valid (M, K)``.  Averaging ``N(phi_i; l, sigma^2)`` over ``l``
    gives ``1 / 2pi`` (sigma << pi), so with the module docstring's cancellations

        g_u(Phi) = e^-L [(1 - p_D) (L / 2pi)^n + n p_D (L / 2pi)^(n-1) / 2pi].

    The yardstick of a lost track (:meth:`ParticleBelief.update`): a cloud that explains
    the scan worse than a target anywhere is not where the target is."""
    n = np.count_nonzero(valid, axis=1)
    log_miss, log_det = _hypothesis_logs(n, sensor.clutter_rate, sensor.p_detect)
    with np.errstate(divide="ignore"):
        return np.logaddexp(log_miss, log_det + np.log(n) - LOG_2PI) - sensor.clutter_rate


def scan_loglik(scan: Scan, particles: np.ndarray, observer: np.ndarray, sensor: BearingModel) -> np.ndarray:
    """Eq. (10) for every particle ``(M, N, >=3)`` and one scan taken at ``observer (3,)``.

    The particles' bearings are :func:`uavsim.sensing.bearing` without its wrap: ``atan2``
    already lies in ``[-pi, pi]``, which is all the likelihood needs.  Under line of sight
    a particle the sensor cannot see has ``p_D = 0``: its likelihood is that of "every
    measurement is clutter", ``e^-L (L / 2pi)^n``, the same for all such particles."""
    expected = np.arctan2(particles[..., 0] - observer[0], particles[..., 1] - observer[1])
    out = _log_likelihood(wrap_angle(scan.bearings), scan.valid, expected, sensor)
    if sensor.line_of_sight:
        hidden = ~sensor.visible(particles[..., :3], np.asarray(observer, float)[:3])  # (M, N)
        if hidden.any():
            all_clutter = _hypothesis_logs(np.count_nonzero(scan.valid, axis=1), sensor.clutter_rate, 0.0)[0]
            out = np.where(hidden, (all_clutter - sensor.clutter_rate)[:, None], out)
    return out
