"""Per-target particle filters with the clutter likelihood of Eq. (10).

004_22b452551a772073.txt Sec. V-A.  All M targets are filtered at once: particles
``(M, N, 6)``, log-weights ``(M, N)``.  No Python loop runs over particles.

* Predict (Eq. 9a): ``x <- A x + B u_j + nu``, ``nu ~ N(0, Q)``; ``u_j`` is the first
  control of target j's guidance re-plan.
* Update (Eq. 9b) with the measurement-set likelihood Eq. (10).  For uniform clutter
  ``p(phi) = 1 / (2 pi)`` and ``Psi(n; L) = e^-L L^n / n!`` the factorials cancel:

      g(Phi | x) = e^-L (L / 2pi)^(n-1) [ (1 - p_D) L / 2pi + p_D sum_i N(phi_i; l(x, s), sigma^2) ]

  evaluated in the log domain as a log-sum-exp over the ``n + 1`` association
  hypotheses ("all clutter", "phi_i is the target"), so nothing underflows.  Residuals
  ``phi_i - l(x, s)`` are wrapped to (-pi, pi].  Several sensors (the fixed-sensor
  baseline) multiply their likelihoods: their log-likelihoods add.
* Systematic resampling when ``ESS = 1 / sum w^2 < threshold N``; optional roughening
  (Gordon, Salmond & Smith 1993): jitter ``K E N^(-1/d)`` per dimension, E the spread of
  the particles before resampling.
* Moments (Eq. 11): weighted mean and covariance.

A degenerate update (every particle has zero likelihood, e.g. a missed detection under
``p_D = 1``) is detected, skipped and reported; weights never become NaN.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import logsumexp

from ..sensing import Scan, Sensor, bearing, wrap_angle
from ..targets import Dynamics
from .traces import pseudo_traces

LOG_2PI = np.log(2.0 * np.pi)


def log_likelihood(bearings: np.ndarray, valid: np.ndarray, expected: np.ndarray, sensor: Sensor) -> np.ndarray:
    """``log g(Phi | x)`` of Eq. (10), closed form for uniform clutter (module docstring).

    Parameters
    ----------
    bearings, valid : (M, K) one scan's padded measurement sets.
    expected : (M, N) noise-free bearings ``l(x, s)`` of the particles.

    Returns
    -------
    (M, N) log-likelihoods (``-inf`` where a particle cannot explain the set).

    References
    ----------
    004_22b452551a772073.txt Eq. (10).
    """
    lam, pd, sig = sensor.clutter_rate, sensor.p_detect, sensor.sigma
    n = valid.sum(axis=1)  # (M,) set sizes
    log_lc = np.log(lam) - LOG_2PI if lam > 0 else -np.inf  # log(L / 2pi)
    log_pd = np.log(pd) if pd > 0 else -np.inf
    log_miss_p = np.log1p(-pd) if pd < 1 else -np.inf

    def clutter(k):  # log (L / 2pi)^k with k = 0 giving 0 even when L = 0
        with np.errstate(invalid="ignore"):
            return np.where(k == 0, 0.0, k * log_lc)

    log_miss = log_miss_p + clutter(n)  # all n measurements are clutter
    log_det = np.where(n >= 1, log_pd + clutter(np.maximum(n - 1, 0)), -np.inf)  # one is the target
    resid = wrap_angle(bearings[:, None, :] - expected[:, :, None])  # (M, N, K)
    log_c = -0.5 * (resid / sig) ** 2 - np.log(sig) - 0.5 * LOG_2PI
    log_c = np.where(valid[:, None, :], log_c, -np.inf)
    terms = np.concatenate([np.broadcast_to(log_miss[:, None, None], log_c.shape[:2] + (1,)),
                            log_det[:, None, None] + log_c], axis=2)
    return -lam + logsumexp(terms, axis=2)


@dataclass
class ParticleFilter:
    """M particle filters in one array; a thin stateful wrapper around pure steps.

    Attributes
    ----------
    particles : (M, N, 6); logw : (M, N) normalised log-weights.
    """

    particles: np.ndarray
    logw: np.ndarray

    @classmethod
    def from_priors(cls, rng: np.random.Generator, means: np.ndarray, covs: np.ndarray, n: int) -> "ParticleFilter":
        """Sample N particles per target from ``N(mean (M, 6), cov (M, 6, 6))``."""
        chol = np.linalg.cholesky(covs)
        z = rng.standard_normal((means.shape[0], n, 6))
        particles = means[:, None, :] + np.einsum("mij,mnj->mni", chol, z)
        return cls(particles, np.full(particles.shape[:2], -np.log(n)))

    @property
    def weights(self) -> np.ndarray:
        return np.exp(self.logw)

    def predict(self, rng: np.random.Generator, a: np.ndarray, b: np.ndarray, q_chol: np.ndarray,
                controls: np.ndarray) -> None:
        """Eq. (9a): ``x <- A x + B u + nu`` with ``controls (M, 3)``."""
        noise = rng.standard_normal(self.particles.shape) @ q_chol.T
        self.particles = self.particles @ a.T + (controls @ b.T)[:, None, :] + noise

    def update(self, loglik: np.ndarray) -> np.ndarray:
        """Eq. (9b) with ``loglik (M, N)``.  Returns (M,) bool: the update was degenerate
        (no particle explains the measurements) and was skipped for that target."""
        logw = self.logw + loglik
        norm = logsumexp(logw, axis=1)
        bad = ~np.isfinite(norm)
        self.logw = np.where(bad[:, None], self.logw, logw - np.where(bad, 0.0, norm)[:, None])
        return bad

    def ess(self) -> np.ndarray:
        """(M,) effective sample size ``1 / sum w^2``."""
        return 1.0 / np.exp(logsumexp(2.0 * self.logw, axis=1))

    def resample(self, rng: np.random.Generator, threshold: float, roughening: float = 0.0) -> np.ndarray:
        """Systematic resampling of the targets whose ESS fell below ``threshold * N``.

        Returns (M,) bool: which targets were resampled.
        """
        m, n, d = self.particles.shape
        which = self.ess() < threshold * n
        if not which.any():
            return which
        idx = systematic_indices(rng, self.weights[which])
        rows = np.flatnonzero(which)
        picked = np.take_along_axis(self.particles[rows], idx[:, :, None], axis=1)
        if roughening > 0:
            # the spread E of the set before resampling: after a degenerate resampling the
            # picked particles may coincide, and their own spread would give no jitter
            spread = self.particles[rows].max(axis=1) - self.particles[rows].min(axis=1)  # (r, d)
            picked = picked + rng.standard_normal(picked.shape) * (roughening * spread * n ** (-1.0 / d))[:, None, :]
        self.particles[rows] = picked
        self.logw[rows] = -np.log(n)
        return which

    def moments(self) -> tuple[np.ndarray, np.ndarray]:
        """Eq. (11): weighted means (M, 6) and covariances (M, 6, 6)."""
        return weighted_moments(self.particles, self.weights)


def systematic_indices(rng: np.random.Generator, weights: np.ndarray) -> np.ndarray:
    """Systematic resampling, one uniform per row: ``weights (R, N)`` -> indices ``(R, N)``.

    Rows are searched at once by offsetting row r's cumulative weights by r.
    """
    r, n = weights.shape
    cum = np.cumsum(weights, axis=1)
    cum /= cum[:, -1:]
    offsets = np.arange(r)[:, None]
    positions = (rng.random((r, 1)) + np.arange(n)[None, :]) / n
    idx = np.searchsorted((cum + offsets).ravel(), (positions + offsets).ravel(), side="right")
    return np.minimum(idx.reshape(r, n) - offsets * n, n - 1)


def weighted_moments(particles: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean (M, d) and covariance (M, d, d) of weighted particles (weights sum to 1 per row)."""
    mean = np.einsum("mn,mnd->md", weights, particles)
    centred = particles - mean[:, None, :]
    cov = np.einsum("mn,mnd,mne->mde", weights, centred, centred)
    return mean, cov


def scan_loglik(scan: Scan, particles: np.ndarray, observer: np.ndarray, sensor: Sensor) -> np.ndarray:
    """Eq. (10) for every particle ``(M, N, 6)`` and one scan taken at ``observer (3,)``."""
    return log_likelihood(scan.bearings, scan.valid, bearing(particles, observer), sensor)


class ParticleBelief:
    """The :class:`uavsim.belief.Belief` of 004 Sec. V-A: M particle filters with the
    clutter likelihood, systematic resampling (and roughening) when the ESS is low, and the
    pseudo-posterior traces of Eq. (12) for the UAV's decision."""

    def __init__(self, rng: np.random.Generator, means: np.ndarray, covs: np.ndarray, n: int,
                 resample_threshold: float, roughening: float, names: tuple[str, ...]):
        self.rng, self.names = rng, names
        self.threshold, self.roughening = resample_threshold, roughening
        self.pf = ParticleFilter.from_priors(rng, means, covs, n)

    def predict(self, dynamics: Dynamics, controls: np.ndarray) -> None:
        self.pf.predict(self.rng, dynamics.a, dynamics.b, dynamics.q_chol, controls)

    def update(self, scans: list[Scan], observers: np.ndarray, sensor: Sensor) -> list[str]:
        if not scans:  # no sensor: the prediction is the posterior
            return []
        loglik = sum(scan_loglik(s, self.pf.particles, o, sensor) for s, o in zip(scans, observers))
        events = [f"{self.names[j]}: degenerate update skipped (no particle explains the bearings)"
                  for j in np.flatnonzero(self.pf.update(loglik))]
        resampled = self.pf.resample(self.rng, self.threshold, self.roughening)
        if resampled.any():
            events.append("resampled " + ", ".join(self.names[j] for j in np.flatnonzero(resampled)))
        return events

    def moments(self) -> tuple[np.ndarray, np.ndarray]:
        return self.pf.moments()

    def traces(self, candidates: np.ndarray, sigma: float) -> np.ndarray:
        return pseudo_traces(candidates, self.pf.particles, self.pf.weights, sigma)

    def samples(self) -> np.ndarray:
        return self.pf.particles.copy()
