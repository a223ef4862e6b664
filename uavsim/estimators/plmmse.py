"""PL-MMSE under Gaussian-mixture noise and its pseudo-linear baselines ([Li2022]).

[Li2022] (Li, Tang, Zhang, Zou 2022), Sec. 2 and Table 1.  Bearings
follow the paper (and [Huang2021]): ``phi = atan2(ty - sy, tx - sx)`` from +x, anticlockwise
(Eq. 3, printed as ``tan^-1`` of the ratio; atan2 keeps the quadrant).

Model, batched over R runs like :mod:`.plkf` (``x (R, 4)``, ``P (R, 4, 4)``, bearings
``(R,)``, observer ``(2,)`` or ``(R, 2)``):

* State ``[tx, ty, vx, vy]`` (7); ``x_k = F x_{k-1} + w`` (9) with ``F`` (11) and the
  process noise entering through ``D`` (12), so ``P- = F P F^T + D Q D^T`` (14).
* Gaussian-mixture (GM) noise: the bearing noise ``e ~ sum_j lambda_j N(0, sigma_j^2)``
  (5)-(6) and the process noise ``w ~ sum_i rho_i N(0, Q_i)``; the filters use the
  mixture covariance ``Q = sum_i rho_i Q_i`` (15)-(16) (a matrix here: the scenarios'
  ``Q_i`` are diagonal matrices).
* Pseudo-linear measurement (8), (10), (17): ``z = [sin phi^, -cos phi^] s = H x - r sin e``
  with ``H = [sin phi^, -cos phi^, 0, 0]`` (the printed transpose and index ``i`` are typos)
  and ``r = |T - S|``.

Exact moments of a zero-mean GM bearing noise, used throughout:
``c1 = E cos e = sum_j lambda_j exp(-sigma_j^2 / 2)`` and
``s2 = E sin^2 e = sum_j lambda_j (1 - exp(-2 sigma_j^2)) / 2``.

Re-derived where the print is garbled (tested in ``tests/test_plmmse.py``):

* Eq. (19): ``R_k = r^2 s2``: the second moment of the pseudo-linear noise ``r sin e``
  (the print lost the square on the range and put a spurious exponential around
  ``(1 - exp(-2 sigma^2)) / 2``).  ``r`` is the predicted range ``|x-(pos) - s|``: the true
  range the print names is unknown to a filter.
* Table 1 step 4 (gain).  The innovation is ``nu = z - H x- = -r^ sin(phi^ - phi_bar)``
  with ``phi_bar`` the predicted bearing.  Linearising the true bearing about
  ``phi_bar`` and averaging over ``e``: ``E[x~ nu] = c1 P- H1^T`` with
  ``H1 = [sin phi_bar, -cos phi_bar, 0, 0]`` (Eq. 23, whose print lost the sines and
  cosines), and ``E[nu^2] = E[H P- H^T] - s2 (P-11 + P-22) + s2 r^2``.  So
  ``K1 = c1 P- H1^T`` (Table 1 prints ``exp(-e_j^2 / 2)``, Tables 2-3 ``exp(-sigma_j^2 / 2)``:
  the latter), and ``K2 = H P- H^T - s2 (P-11 + P-22) + R_k``: the printed trace
  coefficient ``sum rho_i exp((exp(-2 xi_{i-1}^2)) / 2)`` is a garbled
  ``sum lambda_j (exp(-2 sigma_j^2) - 1) / 2 = -s2`` (bearing, not process, weights).
* Table 1 step 6 prints ``K~_k``; it is ``P = P- - K K1^T`` with ``K = K1 / K2``.
* The baselines PLKF (18)-(22), BC-PLKF and IVKF are [Huang2021]'s filters (:mod:`.plkf`, the
  same references [23], [24]) with the bearing variance replaced by ``s2``: for a
  zero-mean symmetric ``e`` the pseudo-linear noise's variance is ``r^2 s2`` and the
  bias of ``H^T`` times it is exactly ``-s2 (x(pos) - s)``, so ``s2`` is the one second
  moment both the PLKF's ``R`` and the BC term need.  (``E e^2`` differs from ``s2`` by
  2x at the line scenario's noise; the paper does not say which it used.)
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from . import plkf
from .plkf import POS, TINY, _row, _sym, predict, pseudo_measurement


@dataclass(frozen=True)
class GaussianMixture:
    """A zero-mean Gaussian mixture ``sum_j w_j N(0, C_j)``: weights ``(n,)`` positive,
    summing to 1 (Eq. 6, 16), and component covariances ``(n, d, d)`` (or variances
    ``(n,)`` for a scalar noise such as the bearing's, Eq. 5)."""

    weights: np.ndarray
    covs: np.ndarray

    def __post_init__(self):
        w = np.atleast_1d(np.asarray(self.weights, float))
        c = np.asarray(self.covs, float)
        c = c[:, None, None] if c.ndim == 1 else c
        if w.ndim != 1 or c.ndim != 3 or len(w) != len(c) or c.shape[1] != c.shape[2]:
            raise ValueError(f"weights (n,) and covs (n, d, d) or (n,) expected, got {w.shape} and {c.shape}")
        if not (np.all(w > 0) and abs(w.sum() - 1) < 1e-12):
            raise ValueError(f"mixture weights must be positive and sum to 1, got {w.tolist()}")
        if not np.allclose(c, np.swapaxes(c, 1, 2)) or np.linalg.eigvalsh(c).min() < -1e-12 * max(1.0, abs(c).max()):
            raise ValueError("mixture covariances must be symmetric positive semi-definite")
        object.__setattr__(self, "weights", w)
        object.__setattr__(self, "covs", c)

    @property
    def cov(self) -> np.ndarray:
        """Eq. (15): the mixture covariance ``sum_j w_j C_j`` (d, d)."""
        return np.einsum("j,jab->ab", self.weights, self.covs)

    def scaled(self, rho: float) -> GaussianMixture:
        """The noise ``rho`` times this one: covariances ``rho^2 C_j`` (Eq. 75's scale)."""
        return GaussianMixture(self.weights, self.covs * rho**2)

    def sample(self, rng: np.random.Generator, size: int) -> np.ndarray:
        """``size`` independent draws ``(size, d)``: a component per draw, then its normal.
        Scaling the mixture by ``rho`` scales the draws of the same ``rng`` state by ``rho``."""
        lam, vec = np.linalg.eigh(self.covs)
        root = vec * np.sqrt(np.clip(lam, 0, None))[:, None, :]  # C_j = root_j root_j^T
        comp = rng.choice(len(self.weights), size=size, p=self.weights)
        return np.einsum("sab,sb->sa", root[comp], rng.standard_normal((size, self.covs.shape[1])))

    def mean_cos(self, k: float = 1.0) -> float:
        """``E cos(k e)`` of a scalar mixture: ``sum_j w_j exp(-k^2 sigma_j^2 / 2)``."""
        if self.covs.shape[1] != 1:
            raise ValueError("mean_cos needs a scalar (bearing) mixture")
        return float(self.weights @ np.exp(-(k**2) * self.covs[:, 0, 0] / 2))

    def mean_sin2(self) -> float:
        """``s2 = E sin^2 e = (1 - E cos 2e) / 2`` (the re-derived Eq. 19 factor)."""
        return (1.0 - self.mean_cos(2.0)) / 2.0


def cv_model(dt: float, process: GaussianMixture) -> tuple[np.ndarray, np.ndarray]:
    """Eq. (11)-(12), (14)-(15): ``F`` and ``D Q D^T`` for the mixture covariance ``Q`` (4, 4)."""
    f = np.eye(4)
    f[0, 2] = f[1, 3] = dt
    d = np.zeros((4, 4))
    d[0, 2] = d[1, 3] = dt**2 / 2
    d[2, 2] = d[3, 3] = dt
    return f, d @ process.cov @ d.T


def pl_mmse_gain(x, p, beta, s, noise: GaussianMixture, pos=POS, r_scale: float = 1.0):
    """Table 1 step 4 (re-derived, module docstring) for predictions ``x (R, n)``,
    ``P (R, n, n)``: returns ``K1 (R, n)``, ``K2 (R,)``, ``z (R,)``, ``H (R, n)``, ``H1 (R, n)``.
    ``r_scale`` multiplies ``R_k``: 1 is Eq. (19) as derived; other values are for
    sensitivity studies only (docs/results/li2022.md, doubling R_k)."""
    beta, s, _ = plkf._broadcast(x, beta, s, 0.0)
    n = x.shape[1]
    z, h = pseudo_measurement(beta, s, n, pos)
    rel = x[:, pos] - s
    r2 = np.sum(rel**2, axis=1)
    phi_bar = np.arctan2(rel[:, 1], rel[:, 0])  # Eq. (23), from the prediction
    h1 = _row(np.stack([np.sin(phi_bar), -np.cos(phi_bar)], -1), n, pos)
    s2 = noise.mean_sin2()
    k1 = noise.mean_cos(1.0) * np.einsum("rij,rj->ri", p, h1)
    trace = p[:, pos[0], pos[0]] + p[:, pos[1], pos[1]]
    k2 = np.einsum("ri,rij,rj->r", h, p, h) - s2 * trace + r_scale * s2 * r2  # R_k = r^2 s2, Eq. (19)
    return k1, k2, z, h, h1


def pl_mmse_update(x, p, beta, s, noise: GaussianMixture, pos=POS, r_scale: float = 1.0):
    """Table 1 steps 4-6: ``K = K1 / K2``, ``x = x- + K (z - H x-)``, ``P = P- - K K1^T``.
    Returns ``(x, P, ok)``; a run whose ``K2`` is not above ``c1^2 H1 P- H1^T`` (the
    updated ``P`` would not be positive semi-definite) keeps its prediction, ``ok`` False."""
    k1, k2, z, h, h1 = pl_mmse_gain(x, p, beta, s, noise, pos, r_scale)
    floor = noise.mean_cos(1.0) * np.einsum("ri,ri->r", h1, k1)  # = c1^2 H1 P- H1^T
    ok = np.isfinite(k2) & (k2 > np.maximum(floor, TINY))
    k = np.where(ok[:, None], k1 / np.where(ok, k2, 1.0)[:, None], 0.0)
    x_new = x + k * (z - np.einsum("ri,ri->r", h, x))[:, None]
    return x_new, _sym(p - k[:, :, None] * k1[:, None, :]), ok


def _baseline(update):
    def gm_update(x, p, beta, s, noise: GaussianMixture, pos=POS, moment: str = "sin2"):
        if moment not in ("sin2", "var"):
            raise ValueError(f"moment must be sin2 or var, got {moment!r}")
        second = noise.mean_sin2() if moment == "sin2" else noise.cov[0, 0]
        return update(x, p, beta, s, np.sqrt(second), pos=pos)

    gm_update.__doc__ = (f"{update.__name__} of :mod:`.plkf` under GM bearing noise: its ``sigma^2`` is "
                         "``s2 = E sin^2 e`` (module docstring; ``moment=\"var\"``: ``E e^2``, for sensitivity "
                         "studies).  Returns ``(x, P, ok)``.")
    return gm_update


UPDATES: dict[str, Callable] = {
    "pl-mmse": pl_mmse_update,
    "plkf": _baseline(plkf.plkf_update),
    "bc-plkf": _baseline(plkf.bc_plkf_update),
    "ivkf": _baseline(plkf.iv_plkf_update),
}
FILTERS = tuple(UPDATES)

Constraint = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]


@dataclass
class PseudoLinearGM:
    """One of :data:`FILTERS` over R runs under GM noise, optionally constrained (Tables 1-3).

    Starts from ``x = x^_{1|1} (R, 4)``, ``P = P_{1|1}``; ``step(beta, s)`` predicts and
    updates.  ``constraint(x, P) -> (x~, ok)`` (e.g. from :mod:`.constraints`) gives the
    constrained estimate ``estimate`` after each update (Table 2 step 5, Table 3 step 5);
    with ``feedback`` False (the tables' reading: step 6 predicts from ``x^``) the filter
    itself stays unconstrained, with ``feedback`` True ``x~`` replaces ``x^``.
    ``degenerate`` counts per run the updates skipped and constraints not applied;
    ``options`` are keyword arguments of the update (``r_scale``, ``moment``)."""

    kind: str
    f: np.ndarray
    q: np.ndarray
    noise: GaussianMixture
    x: np.ndarray
    p: np.ndarray
    constraint: Constraint | None = None
    feedback: bool = False
    options: dict = field(default_factory=dict)
    estimate: np.ndarray = field(init=False)
    degenerate: np.ndarray = field(init=False)

    def __post_init__(self):
        if self.kind not in UPDATES:
            raise ValueError(f"unknown filter {self.kind!r}; choose from {', '.join(FILTERS)}")
        self.x = np.atleast_2d(np.asarray(self.x, float)).copy()
        self.p = np.broadcast_to(self.p, (self.x.shape[0], *np.shape(self.p)[-2:])).astype(float)
        self.degenerate = np.zeros(self.x.shape[0], int)
        self._constrain()

    def _constrain(self) -> None:
        if self.constraint is None:
            self.estimate = self.x
            return
        self.estimate, ok = self.constraint(self.x, self.p)
        self.degenerate += ~ok
        if self.feedback:
            self.x = self.estimate

    def step(self, beta, s) -> None:
        self.x, self.p = predict(self.x, self.p, self.f, self.q)
        self.x, self.p, ok = UPDATES[self.kind](self.x, self.p, beta, s, self.noise, **self.options)
        self.degenerate += ~ok
        self._constrain()
