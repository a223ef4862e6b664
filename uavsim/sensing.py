"""Bearing sensor with missed detections and Poisson clutter.

[Papaioannou2023] Eq. (4) and Sec. III-C: on target j's channel the UAV at s
receives, each step,

* with probability ``p_D`` one target bearing ``phi = l(x, s) + w``, ``w ~ N(0, sigma^2)``,
  ``l(x, s) = atan2(x_x - s_x, x_y - s_y)`` (from north, clockwise);
* ``Poisson(Lambda)`` false alarms, uniform on ``(-pi, pi]``.

Every bearing is wrapped to ``(-pi, pi]``.  A scan is stored padded: ``(M, K)`` arrays
with a ``valid`` mask, K the largest set size of that scan.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .declare import degrees, setting


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


@dataclass(frozen=True)
class Sensor:
    """Sensor parameters of Sec. III-C, the same for every channel.

    Attributes
    ----------
    sigma : bearing noise std (rad); p_detect : p_D; clutter_rate : Lambda (per scan, per channel).
    """

    sigma: float = setting("sigma_deg", 1.0, unit="deg", lo=0.001, hi=SIGMA_MAX_DEG, **degrees,
                           doc="bearing noise standard deviation sigma (Eq. 4); at most 22.5, where the "
                               "wrapped tail of the noise (taken as Gaussian on the line by the bound) is below 1e-15")
    p_detect: float = setting("p_detect", 0.95, lo=0, hi=1, doc="p_D, that a scan holds the target's bearing")
    clutter_rate: float = setting("clutter_rate", 1.0, unit="per scan", lo=0, hi=100,
                                  doc="Lambda, mean false alarms per scan on each target's channel (Poisson)")


@dataclass(frozen=True, eq=False)
class Scan:
    """One scan of M channels, padded to K entries.

    Attributes
    ----------
    bearings : (M, K) rad, 0 where not valid.
    valid : (M, K) bool, entry is a received measurement.
    from_target : (M, K) bool, entry is the target's own bearing (truth, for recording).
    """

    bearings: np.ndarray
    valid: np.ndarray
    from_target: np.ndarray

    @property
    def counts(self) -> np.ndarray:
        """(M,) number of measurements ``n^j`` per channel."""
        return self.valid.sum(axis=1)


def observe(
    rng: np.random.Generator, sensor: Sensor, targets: np.ndarray, observer: np.ndarray
) -> Scan:
    """Draw one scan of Eq. (4) with missed detections and clutter.

    Parameters
    ----------
    rng : the only source of randomness.
    targets : (M, >=2) true target positions; observer : (>=2,) sensor position.

    Returns
    -------
    Scan with the target bearing (if detected) in column 0 of its channel, then clutter.
    """
    m = targets.shape[0]
    detected = rng.random(m) < sensor.p_detect
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
    return Scan(bearings=wrap_angle(bearings), valid=valid, from_target=from_target)
