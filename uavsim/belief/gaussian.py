"""Gaussian beliefs: [Huang2021]'s pseudo-linear Kalman filters in place of particles.

M targets tracked by one of [Huang2021]'s filters (``filter.kind``;
clutter-free missions only, enforced by the mission validation).  The 6-D state
``[x, y, z, vx, vy, vz]`` is predicted exactly (Eq. 9a in moments, :meth:`Dynamics.predict`);
a detection updates it with [Huang2021]'s pseudo-linear step on the horizontal position
``(0, 1)`` and velocity ``(3, 4)``.  Bearings convert at this edge: [Huang2021] measures from +x
anticlockwise, ``beta = pi/2 - phi``.  A channel without a detection keeps its prediction;
a degenerate update is skipped and reported.  VC-PLKF bounds the horizontal speed to
``[0, v_max]`` (the guidance speed limit).  The UAV's decision uses Eq. (12)-(13)
linearised (:func:`.traces.gaussian_traces`).
"""

from __future__ import annotations

import numpy as np

from ..estimators.plkf import UPDATES
from ..metrics import credible_level
from ..sensing import BearingModel, Scan
from ..targets import Dynamics
from .traces import gaussian_traces


class GaussianBelief:
    """The :class:`uavsim.belief.Belief` of a pseudo-linear filter.

    Attributes
    ----------
    mean : (M, 6); cov : (M, 6, 6).
    """

    def __init__(self, kind: str, means: np.ndarray, covs: np.ndarray, v_max: float, names: tuple[str, ...]):
        if kind not in UPDATES:
            raise ValueError(f"unknown filter {kind!r}; choose from {', '.join(UPDATES)}")
        self.kind, self.names = kind, names
        self.mean, self.cov = means.astype(float).copy(), covs.astype(float).copy()
        self.kw = {"v_min": 0.0, "v_max": v_max} if kind == "vc-plkf" else {}
        self._applied = np.zeros((len(means), 2))

    def predict(self, dynamics: Dynamics, controls: np.ndarray, split: None = None) -> None:
        """``split`` (halves moving by different plans) is for particle beliefs only."""
        self.mean, self.cov = dynamics.predict(self.mean, self.cov, controls)
        self._applied = controls[:, :2].copy()

    def applied(self) -> np.ndarray:
        """``(M, 2)`` the ground force of the last prediction."""
        return self._applied.copy()

    def update(self, scans: list[Scan], observers: np.ndarray, sensor: BearingModel) -> list[str]:
        """Each sensor's clutter-free scan in turn."""
        events = []
        for scan, observer in zip(scans, observers):
            events += [f"{self.names[j]}: degenerate {self.kind} update skipped"
                       for j in np.flatnonzero(self._update(scan, observer, sensor.sigma))]
        return events

    def _update(self, scan: Scan, observer: np.ndarray, sigma: float) -> np.ndarray:
        """One scan from ``observer (3,)``.  Returns (M,) bool: degenerate."""
        m = len(self.mean)
        detected = scan.valid.any(axis=1)
        if not detected.any():
            return np.zeros(m, bool)
        phi = scan.bearings[np.arange(m), np.argmax(scan.valid, axis=1)]
        x, p, ok = UPDATES[self.kind](self.mean, self.cov, np.pi / 2 - phi, observer[:2], sigma,
                                      pos=(0, 1), vel=(3, 4), **self.kw)
        take = detected & ok
        self.mean = np.where(take[:, None], x, self.mean)
        self.cov = np.where(take[:, None, None], p, self.cov)
        return detected & ~ok

    def moments(self) -> tuple[np.ndarray, np.ndarray]:
        return self.mean.copy(), self.cov.copy()

    def traces(self, candidates: np.ndarray, sensor: BearingModel) -> np.ndarray:
        return gaussian_traces(candidates, self.mean, self.cov, sensor)

    def drain_notes(self) -> list[str]:
        return []

    def samples(self) -> None:
        return None

    def draw(self, rng: np.random.Generator, k: int) -> np.ndarray:
        """``N(mean, cov)`` through the covariance's eigen-decomposition (its z block is
        ~1e-10, and rounding may leave an eigenvalue a hair below zero: clipped to 0)."""
        val, vec = np.linalg.eigh(self.cov)
        z = rng.standard_normal((len(self.mean), k, 6)) * np.sqrt(np.maximum(val, 0.0))[:, None, :]
        return self.mean[:, None, :] + np.einsum("mij,mkj->mki", vec, z)

    @property
    def lost(self) -> np.ndarray:
        """(M,) no track-loss detection here: never lost."""
        return np.zeros(len(self.mean), dtype=bool)

    def credible_level(self, truth: np.ndarray, mean: np.ndarray, cov: np.ndarray) -> np.ndarray:
        return credible_level(truth, mean, cov)
