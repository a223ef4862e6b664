"""Per-target particle filters with the clutter likelihood of Eq. (10).

[Papaioannou2023] Sec. V-A.  All M targets are filtered at once: particles
``(M, N, 6)``, log-weights ``(M, N)``.  No Python loop runs over particles.

* Predict (Eq. 9a): ``x <- A x + B u_j + nu``, ``nu ~ N(0, Q)``; ``u_j`` is the first
  control of target j's guidance re-plan.  Optionally the cloud is split in two
  (:func:`halves`) and each half moves by the plan from its own mean (``[filter]
  plan_clusters = 2``, see :mod:`uavsim.sim`).  With ``[filter] noise_scales`` of two or
  more values each particle carries one of them and its noise is ``N(0, scale Q)``; a
  particle redraws its scale with probability ``scale_switch`` per step, each scale with
  its chance in ``noise_shares`` (a jump-Markov model [McGinnity2000]), and the weights
  keep the scales the bearings support.
  With ``[filter] motion = "commit"`` the cloud is instead split once into K clusters
  (:func:`clusters`), each cluster's plan is made once and flown open loop, and a particle
  moves by its cluster's force plus the plan's response to its own start's offset from the
  cluster's mean (:meth:`ParticleBelief.predict_committed`; see :mod:`uavsim.sim`).
  ``[filter] noise_space`` says where such a particle's noise goes: ``"state"`` adds it to
  the state (Eq. 9a); ``"start"`` adds its ``[x, y, vx, vy]`` part to the particle's start
  offset ``d`` and moves the state by the committed plan's response ``G_t (d_new - d)``
  (``G_t = d x_t / d x_0``, :attr:`ParticleBelief.sens`), so the particle flies the plan
  of its new start and the noise contracts as the plans do (a planned truth's spread
  shrinks to its goal point by the horizon's end); ``"split"`` sends the highest level (the
  only one, if one) to the state, where it lets particles leave the plans' affine model (a
  target on another route than its cluster's plan), and the others to the start.  With
  ``[filter] route_switch`` a particle may also take one of its cluster's nearest clusters'
  plans, moved to where that plan puts its start (:meth:`ParticleBelief._switch_routes`):
  the nearest cluster's plan is often not the route the truth from that start takes.
* Update (Eq. 9b) with the measurement-set likelihood Eq. (10).  For uniform clutter
  ``p(phi) = 1 / (2 pi)`` and ``Psi(n; L) = e^-L L^n / n!`` the factorials cancel:

      g(Phi | x) = e^-L (L / 2pi)^(n-1) [ (1 - p_D) L / 2pi + p_D sum_i N(phi_i; l(x, s), sigma^2) ]

  evaluated in the log domain as a log-sum-exp over the ``n + 1`` association
  hypotheses ("all clutter", "phi_i is the target"), so nothing underflows.  Residuals
  ``phi_i - l(x, s)`` are wrapped to (-pi, pi].  Several sensors (the fixed-sensor
  baseline) multiply their likelihoods: their log-likelihoods add.
* Systematic resampling when ``ESS = 1 / sum w^2 < threshold N``; optional roughening
  [Gordon1993]: jitter ``K E N^(-1/d)`` per dimension, E the spread of
  the particles before resampling.
* Moments (Eq. 11): weighted mean and covariance.
* Keep-out (``[filter] keep_out``, not in the paper): the targets keep out of the
  obstacles, as the true ones do.  The prior is ``N(mu_0, Sigma_0)`` restricted to the
  starts a true target may take (:func:`restricted_draws`; the truth's own test,
  :func:`uavsim.truth.clear_starts`), and a particle a prediction carries into an obstacle
  weighs zero (:meth:`ParticleBelief.keep_out`): the transition density truncated to free
  space, applied as a weight ([Papaioannou2023]'s filter lets particles cross buildings).

A degenerate update (every particle has zero likelihood, e.g. a missed detection under
``p_D = 1``) is detected, skipped and reported; weights never become NaN.
"""

from __future__ import annotations

import functools

import numpy as np

from ..metrics import credible_level
from ..sensing import EXP_FLOOR, BearingModel, Scan
from ..targets import HORIZONTAL, Dynamics
from . import recovery
from .traces import inverse_cdf, pseudo_traces

PRIOR_ROUNDS = 8  # rejection rounds of a restricted prior (restricted_draws)
PRIOR_BATCH = 100  # a round draws at most this many times the particles per target
COLLAPSED_M = 1e-3  # m: a cloud with a smaller position spread has collapsed (ParticleBelief._collapsed)
ROUTE_NEIGHBOURS = 3  # the clusters a particle may switch to (ParticleBelief._switch_routes)
SWITCH_SUPPORT = 13.8  # chi-square(2) at 0.999: a route switch's reach (_switch_routes, within_spread)


class ParticleFilter:
    """M particle filters in one array; a thin stateful wrapper around pure steps.

    Attributes
    ----------
    particles : (M, N, 6); logw : (M, N) normalised log-weights; weights : (M, N)
    ``exp(logw)``, computed once per new ``logw`` (the ESS test, the moments and the
    decision all read it).
    """

    def __init__(self, particles: np.ndarray, logw: np.ndarray, scales: np.ndarray | None = None,
                 switch: float = 0.0, rng: np.random.Generator | None = None, shares: np.ndarray | None = None):
        self.particles, self.logw = particles, logw
        self._work: dict = {}  # scratch buffers
        # jump-Markov process noise: each particle's Q is scales[mode] Q (None: unit Q for all)
        self.levels = None if scales is None or len(scales) < 2 else np.sqrt(np.asarray(scales, float))
        self.unit = 1.0 if scales is None or len(scales) != 1 else float(np.sqrt(scales[0]))  # one scale: every Q
        self.switch = switch
        # a level's chance when a particle draws one (None: all alike); cumulative, for inverse-CDF draws
        self.cum = (None if shares is None or self.levels is None or np.ptp(shares) == 0
                    else np.cumsum(shares)[:-1])
        self.mode = None if self.levels is None else self.draw_levels(rng, particles.shape[:2])
        self.applied = np.zeros((*particles.shape[:2], 2))  # (M, N) the ground force each particle moved by last
        self.label = np.zeros(particles.shape[:2], np.intp)  # (M, N) each particle's cluster (motion = "commit")
        self.offset = np.zeros((*particles.shape[:2], 4))  # (M, N, 4) its start less its cluster's mean, HORIZONTAL

    @property
    def logw(self) -> np.ndarray:
        return self._logw

    @logw.setter
    def logw(self, value: np.ndarray) -> None:
        self._logw, self._weights = value, None

    @property
    def weights(self) -> np.ndarray:
        if self._weights is None:
            self._weights = np.exp(self._logw)
        return self._weights

    @classmethod
    def from_priors(cls, rng: np.random.Generator, means: np.ndarray, covs: np.ndarray, n: int,
                    scales: np.ndarray | None = None, switch: float = 0.0, particles: np.ndarray | None = None,
                    shares: np.ndarray | None = None) -> "ParticleFilter":
        """Sample N particles per target from ``N(mean (M, 6), cov (M, 6, 6))``, or start
        from ``particles (M, N, 6)`` drawn already (:func:`restricted_draws`); ``scales``,
        ``switch``: see :meth:`predict`; ``shares``: each level's chance when a particle
        draws one (None: all alike)."""
        if particles is None:
            particles = restricted_draws(rng, means, covs, n)[0]
        return cls(particles, np.full(particles.shape[:2], -np.log(n)), scales, switch, rng, shares)

    def predict(self, rng: np.random.Generator, a: np.ndarray, b: np.ndarray, q_chol: np.ndarray,
                controls: np.ndarray, split: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        """Eq. (9a): ``x <- A x + B u + nu`` with ``controls (M, 3)``, or ``(M, N, 3)`` one per
        particle; ``split = (mask (M, N) bool, other (M, 3))``: the masked particles take
        ``other`` instead.  With noise
        levels (``scales`` of :meth:`from_priors`, two or more) particle n's ``nu`` is
        ``sqrt(scales[mode_n]) L z`` and ``mode`` jumps first (module docstring); one scale
        multiplies every particle's Q.

        The noise goes through two buffers kept between calls: fresh temporaries of this
        size cost page faults on every step (the allocator returns them to the system)."""
        x = self.particles @ a.T
        own = controls if controls.ndim == 3 else None  # (M, N, 3): added after the noise
        if own is not None:
            controls = np.zeros((len(x), own.shape[-1]))
        if q_chol is None:  # no process noise here (a committed cloud's is in its starts)
            _affine_rows(x, None, controls @ b.T)
        elif np.any(np.tril(q_chol, -1)):
            noise = self.noise(rng, _scratch(self._work, "z", x.shape))
            x += np.matmul(noise, q_chol.T, out=_scratch(self._work, "noise", x.shape))
            _affine_rows(x, None, controls @ b.T)
        else:  # a diagonal Q (every mission file's): L z is a scaling, done with B u in one wide pass
            x += _affine_rows(self.noise(rng, _scratch(self._work, "z", x.shape)), np.diagonal(q_chol), controls @ b.T)
        self.applied[:] = controls[:, None, :2]
        if own is not None:
            x += own @ b.T
            self.applied[:] = own[..., :2]
        if split is not None:
            mask, other = split
            x += mask[..., None] * ((other - controls) @ b.T)[:, None, :]
            np.copyto(self.applied, other[:, None, :2], where=mask[..., None])
        self.particles = x

    def noise(self, rng: np.random.Generator, out: np.ndarray) -> np.ndarray:
        """``out (M, N, d)`` filled with standard normals, each particle's scaled by the square
        root of its noise level (which jumps first, module docstring) or of the one scale."""
        noise = rng.standard_normal(out=out)
        if self.levels is not None:
            jump = rng.random(self.mode.shape) < self.switch
            self.mode[jump] = self.draw_levels(rng, int(jump.sum()))
            noise *= self.levels[self.mode][..., None]
        elif self.unit != 1.0:
            noise *= self.unit
        return noise

    def draw_levels(self, rng: np.random.Generator, size) -> np.ndarray:
        """Noise levels drawn with the chances ``shares`` (all alike when None)."""
        if self.cum is None:
            return rng.integers(len(self.levels), size=size)
        return np.searchsorted(self.cum, rng.random(size), side="right")

    def update(self, loglik: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Eq. (9b) with ``loglik (M, N)``.  Returns ``(bad, evidence)``: (M,) bool, the
        update was degenerate (no particle explains the measurements) and was skipped for
        that target; (M,) ``log sum_n w_n g(Phi | x_n)``, the scan's likelihood under the
        predicted cloud (``-inf`` where degenerate)."""
        logw = self.logw + loglik
        top = logw.max(axis=1)  # (M,) not finite: every particle -inf (or a NaN)
        bad = ~np.isfinite(top)
        if bad.any():
            top[bad] = 0.0
        logw -= top[:, None]
        shifted = np.maximum(logw, EXP_FLOOR)  # see _shared_shift: each sum is >= 1
        log_sum = np.log(np.exp(shifted, out=shifted).sum(axis=1))
        logw -= log_sum[:, None]
        evidence = np.where(bad, -np.inf, top + log_sum)
        if bad.any():
            logw[bad] = self.logw[bad]
        self.logw = logw
        return bad, evidence

    def ess(self) -> np.ndarray:
        """(M,) effective sample size ``1 / sum w^2``."""
        w = self.weights
        return 1.0 / (w[:, None, :] @ w[:, :, None])[:, 0, 0]

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
        flat = (idx + (rows * n)[:, None]).ravel()  # rows of the (M N, d) particle table
        picked = self.particles.reshape(m * n, d).take(flat, axis=0).reshape(rows.size, n, d)
        if roughening > 0:
            # the spread E of the set before resampling: after a degenerate resampling the
            # picked particles may coincide, and their own spread would give no jitter
            spread = self.particles[rows].max(axis=1) - self.particles[rows].min(axis=1)  # (r, d)
            picked = picked + rng.standard_normal(picked.shape) * (roughening * spread * n ** (-1.0 / d))[:, None, :]
        self.particles[rows] = picked
        if self.mode is not None:
            self.mode[rows] = self.mode.reshape(-1).take(flat).reshape(rows.size, n)
        self.applied[rows] = self.applied.reshape(m * n, 2).take(flat, axis=0).reshape(rows.size, n, 2)
        self.label[rows] = self.label.reshape(-1).take(flat).reshape(rows.size, n)
        self.offset[rows] = self.offset.reshape(m * n, 4).take(flat, axis=0).reshape(rows.size, n, 4)
        logw = self.logw.copy()
        logw[rows] = -np.log(n)
        self.logw = logw
        return which

    def moments(self) -> tuple[np.ndarray, np.ndarray]:
        """Eq. (11): weighted means (M, 6) and covariances (M, 6, 6)."""
        return weighted_moments(self.particles, self.weights, self._work)


def within_spread(positions: np.ndarray, weights: np.ndarray, rows: np.ndarray, starts: np.ndarray,
                  steps: np.ndarray) -> np.ndarray:
    """``(S,)`` bool: a step ``steps (S, 2)`` from ``starts (S, 2)`` stays within cloud
    ``rows (S,)``: it is no longer than the cloud is wide, or it ends inside the cloud
    (squared Mahalanobis length, or distance from the weighted mean, in the cloud's
    weighted covariance at most :data:`SWITCH_SUPPORT`); the clouds: ``positions (M, N, 2)``,
    ``weights (M, N)``.  In a cloud of no spread only a zero step, or one to the mean, is."""
    mean, cov = weighted_moments(positions, weights)
    both = np.stack([steps, starts + steps - mean[rows]], axis=-1)  # (S, 2, 2): the step, the landing point
    sol = np.linalg.solve(cov[rows] + 1e-9 * np.eye(2), both)
    return (both * sol).sum(axis=1).min(axis=1) <= SWITCH_SUPPORT


def restricted_draws(rng: np.random.Generator, means: np.ndarray, covs: np.ndarray, n: int, clear=None,
                     rounds: int = PRIOR_ROUNDS) -> tuple[np.ndarray, np.ndarray]:
    """``(M, n, 6)`` draws from ``N(means (M, 6), covs (M, 6, 6))`` restricted to the
    states ``clear((M, K, 6)) -> (M, K)`` bool keeps (None: every one), and ``(M,)`` how
    many of each target's are not restricted.

    Rejection, vectorised over targets: each round draws for every target 1.2 times as many
    as the target that needs most expects to need at its share of clear first draws (at
    most :data:`PRIOR_BATCH` times n), and each target's clear draws fill its open places.
    After ``rounds`` rounds the places still open keep a draw ``clear`` refused, counted:
    the caller reports them (nothing is fixed silently)."""
    m = len(means)
    chol = np.linalg.cholesky(covs)

    def draw(k: int) -> np.ndarray:
        return means[:, None, :] + np.einsum("mij,mkj->mki", chol, rng.standard_normal((m, k, 6)))

    x = draw(n)
    if clear is None:
        return x, np.zeros(m, int)
    ok = clear(x)
    accept = np.maximum(ok.mean(axis=1), 1.0 / PRIOR_BATCH)  # (M,) each target's share of clear draws
    for _ in range(rounds):
        need = n - ok.sum(axis=1)
        if not need.any():
            break
        new = draw(int(min(np.ceil(1.2 * need / accept).max(), PRIOR_BATCH * n)))
        good = clear(new)
        rank = np.cumsum(good, axis=1) - 1  # (M, K) a clear draw's place among its target's
        holes = np.argsort(ok, axis=1, kind="stable")  # (M, n) each target's open places first
        tm, tk = np.nonzero(good & (rank < need[:, None]))
        place = holes[tm, rank[tm, tk]]
        x[tm, place], ok[tm, place] = new[tm, tk], True
    return x, n - ok.sum(axis=1)


def halves(particles: np.ndarray, weights: np.ndarray, iters: int = 10) -> np.ndarray:
    """``(M, N)`` bool: each cloud split in two by weighted 2-means on ``[x, y, vx, vy]``,
    each scaled by its standard deviation (a guidance plan depends on position and
    velocity alike).  Lloyd's iterations start from five hyperplanes through the mean
    (normal to each scaled axis and to the principal axis; scaling hides a bimodal axis
    from the principal axis alone) and the split with the largest between-halves sum of
    squares is kept.  Deterministic; a side may be empty."""
    z = particles[..., [0, 1, 3, 4]]
    z = z - np.einsum("mn,mni->mi", weights, z)[:, None, :]
    sd = np.sqrt(np.einsum("mn,mni->mi", weights, z * z))
    z /= np.where(sd > 0, sd, 1.0)[:, None, :]
    _, vecs = np.linalg.eigh(np.einsum("mn,mni,mnj->mij", weights, z, z))
    normals = np.concatenate([np.broadcast_to(np.eye(4), (len(z), 4, 4)), vecs[:, None, :, -1]], axis=1)  # (M, 5, 4)
    side = np.einsum("mni,mdi->mdn", z, normals) > 0  # (M, 5, N)
    for _ in range(iters):
        c0, c1, m0, m1 = _centres(z, weights, side)
        new = np.einsum("mni,mdi->mdn", z, c1 - c0) > 0.5 * ((c1 * c1).sum(-1) - (c0 * c0).sum(-1))[..., None]
        if np.array_equal(new, side):
            break
        side = new
    c0, c1, m0, m1 = _centres(z, weights, side)
    between = m0 * (c0 * c0).sum(-1) + m1 * (c1 * c1).sum(-1)  # (M, 5)
    return side[np.arange(len(z)), np.argmax(between, axis=1)]


def centred(particles: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``[x, y, vx, vy]`` of ``particles (M, N, 6)`` less their weighted mean ``(M, N, 4)``, and
    their weighted standard deviations under ``weights (M, N)`` ``(M, 4)``, 1 where a cloud has
    none: the scale of :func:`clusters` and of :func:`cluster_neighbours`."""
    z = particles[..., HORIZONTAL]
    z = z - np.einsum("mn,mni->mi", weights, z)[:, None, :]
    sd = np.sqrt(np.einsum("mn,mni->mi", weights, z * z))
    return z, np.where(sd > 0, sd, 1.0)


def clusters(particles: np.ndarray, weights: np.ndarray, k: int, iters: int = 20) -> np.ndarray:
    """``(M, N)`` labels in ``range(k)``: each cloud in ``k`` clusters by weighted k-means on
    ``[x, y, vx, vy]`` scaled by its standard deviations (as :func:`halves`), Lloyd's
    iterations from the farthest-point rule (the weighted particle farthest from the mean,
    then each next the farthest from the centres so far).  Deterministic; a cluster may be
    empty (a cloud of fewer than ``k`` distinct weighted particles)."""
    z, sd = centred(particles, weights)
    z /= sd[:, None, :]
    rows, live = np.arange(len(z)), weights > 0
    centres = np.empty((len(z), k, 4))
    near = (z * z).sum(-1)  # (M, N) squared distance to the nearest centre so far (the mean, at first)
    for c in range(k):
        centres[:, c] = z[rows, np.argmax(np.where(live, near, -1.0), axis=1)]
        gap = ((z - centres[:, c, None]) ** 2).sum(-1)
        near = np.minimum(near, gap) if c else gap
    label = None
    for _ in range(iters):
        d = (centres * centres).sum(-1)[:, None, :] - 2.0 * z @ centres.transpose(0, 2, 1)  # (M, N, k) + |z|^2
        new = np.argmin(d, axis=2)
        if label is not None and np.array_equal(new, label):
            break
        label = new
        member = (label[..., None] == np.arange(k)) * weights[..., None]  # (M, N, k)
        mass = member.sum(axis=1)
        sums = np.einsum("mnk,mni->mki", member, z)
        centres = np.where(mass[..., None] > 0, sums / np.where(mass > 0, mass, 1.0)[..., None], centres)
    return label


def reference_clusters(particles: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Clusters of an equally weighted reference cloud ``particles (M, N, 6)`` (:func:`clusters`)
    for other clouds to join (:func:`join_clusters`): each cluster's mean ``(M, k, 6)`` and
    covariance ``(M, k, 6, 6)``, the cloud's ``[x, y, vx, vy]`` standard deviations ``(M, 4)``
    (the clustering's scale) and which clusters hold particles ``(M, k)``."""
    weights = np.full(particles.shape[:2], 1.0 / particles.shape[1])
    label = clusters(particles, weights, k)
    parts, mass = cluster_weights(weights, label, k)
    means, covs = part_moments(particles, parts)
    return means, covs, centred(particles, weights)[1], mass > 0


def join_clusters(particles: np.ndarray, means: np.ndarray, scale: np.ndarray, live: np.ndarray) -> np.ndarray:
    """``(M, N)`` labels: each of ``particles (M, N, 6)`` joins the cluster of
    :func:`reference_clusters` (``means (M, k, 6)``, ``scale (M, 4)``, ``live (M, k)``) whose
    mean is nearest in ``[x, y, vx, vy]`` scaled by ``scale``: the reference's k-means cells,
    where its means are its centres."""
    return nearest_clusters(particles, means, scale, live, 1)[..., 0]


def nearest_clusters(particles: np.ndarray, means: np.ndarray, scale: np.ndarray, live: np.ndarray, c: int
                     ) -> np.ndarray:
    """``(M, N, c)`` each particle's ``c`` nearest live clusters, nearest first (as
    :func:`join_clusters` measures); where fewer than ``c`` are live, the nearest repeats."""
    z = particles[..., HORIZONTAL] / scale[:, None, :]
    m = means[..., HORIZONTAL] / scale[:, None, :]  # (M, k, 4)
    d = (m * m).sum(-1)[:, None, :] - 2.0 * z @ m.transpose(0, 2, 1)  # (M, N, k) + |z|^2
    d = np.where(live[:, None, :], d, np.inf)
    order = np.argsort(d, axis=2, kind="stable")[..., :c]
    far = ~np.take_along_axis(live[:, None, :], order, axis=2)
    return np.where(far, order[..., :1], order)


def cluster_neighbours(means: np.ndarray, scale: np.ndarray, live: np.ndarray) -> np.ndarray:
    """``(M, k, min(k, ROUTE_NEIGHBOURS))`` each cluster's nearest other clusters by their
    ``means (M, k, 6)`` in ``[x, y, vx, vy]`` scaled by ``scale (M, 4)``: the non-empty ones
    (``live (M, k)``) first, then empty ones, then the cluster itself (when there are too few
    others)."""
    c = means[..., HORIZONTAL] / scale[:, None, :]
    d = ((c[:, :, None] - c[:, None, :]) ** 2).sum(-1)  # (M, k, k)
    d = np.where(live[:, None, :], d, np.inf)
    k = means.shape[1]
    d[:, np.arange(k), np.arange(k)] = np.nan  # argsort puts NaN after inf
    return np.argsort(d, axis=2, kind="stable")[..., :ROUTE_NEIGHBOURS]


def cluster_weights(weights: np.ndarray, label: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """``(parts (M, k, N), mass (M, k))``: the weights ``(M, N)`` of each of ``k`` clusters
    labelled ``label (M, N)`` (a split's mask is labels 0 and 1), renormalised within the
    cluster (an empty cluster takes the whole cloud's), and each cluster's share of the weight."""
    parts = weights[:, None, :] * (label[:, None, :] == np.arange(k)[None, :, None])
    mass = parts.sum(axis=2)
    safe = np.where(mass > 0, mass, 1.0)[..., None]
    return np.where(mass[..., None] > 0, parts / safe, weights[:, None, :]), mass


def by_label(per_cluster: np.ndarray, label: np.ndarray) -> np.ndarray:
    """``(M, N, ...)``: each particle's row of ``per_cluster (M, k, ...)`` under ``label (M, N)``,
    by one ``take`` on the flattened clusters (``np.take_along_axis`` with broadcast trailing
    axes is 50 times slower at 8 x 5000 particles and (6, 4) rows)."""
    m, k = per_cluster.shape[:2]
    flat = (label + np.arange(m)[:, None] * k).ravel()
    rows = per_cluster.reshape(m * k, -1).take(flat, axis=0)
    return rows.reshape(*label.shape, *per_cluster.shape[2:])


def label_mass(weights: np.ndarray, label: np.ndarray, k: int) -> np.ndarray:
    """``(M, k)`` each cluster's share of the weights ``(M, N)`` under ``label (M, N)``: the
    ``mass`` of :func:`cluster_weights` without its ``(M, k, N)`` parts (one pass)."""
    rows = np.arange(len(label))[:, None] * k
    return np.bincount((label + rows).ravel(), weights.ravel(), minlength=len(label) * k).reshape(len(label), k)


def part_moments(particles: np.ndarray, parts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Weighted means ``(M, k, 6)`` and covariances ``(M, k, 6, 6)`` of the clouds
    ``particles (M, N, 6)`` under each of the weights ``parts (M, k, N)``."""
    means, covs = zip(*(weighted_moments(particles, parts[:, c]) for c in range(parts.shape[1])))
    return np.stack(means, axis=1), np.stack(covs, axis=1)


def _centres(z, weights, side):
    """Weighted centres ``(M, D, 4)`` and masses ``(M, D)`` of both sides of ``D`` splits
    of a cloud ``z (M, N, 4)`` with weighted mean zero (an empty side has mass 0; its centre means nothing)."""
    w1 = weights[:, None, :] * side
    m1 = w1.sum(-1)
    m0 = 1.0 - m1
    c1 = np.einsum("mdn,mni->mdi", w1, z) / np.where(m1 > 0, m1, 1.0)[..., None]
    c0 = -c1 * (m1 / np.where(m0 > 0, m0, 1.0))[..., None]
    return c0, c1, m0, m1


def systematic_indices(rng: np.random.Generator, weights: np.ndarray, k: int | None = None) -> np.ndarray:
    """Systematic resampling, one uniform per row: ``weights (R, N)`` -> indices ``(R, k)``
    (``k = N`` by default).

    (:func:`.traces.inverse_cdf` of the positions ``(u_r + i) / k``).
    """
    r, n = weights.shape
    k = n if k is None else k
    return inverse_cdf(weights, (rng.random((r, 1)) + np.arange(k)[None, :]) / k)


def weighted_moments(particles: np.ndarray, weights: np.ndarray, work: dict | None = None
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Mean (M, d) and covariance (M, d, d) of weighted particles (weights sum to 1 per row).

    Computed on the transposed particles ``(M, d, N)``: every elementwise pass then runs
    along N (a pass broadcast along a last axis of length d is several times slower), and
    the two sums are batched matrix products.  ``work``: a dict of scratch buffers kept
    between calls (see :meth:`ParticleFilter.predict`)."""
    xt = particles.transpose(0, 2, 1)  # (M, d, N) view
    mean = (xt @ weights[:, :, None])[..., 0]
    centred, scaled = (_scratch(work, name, xt.shape) for name in ("centred", "scaled"))
    np.subtract(xt, mean[:, :, None], out=centred)  # (M, d, N) contiguous
    np.multiply(centred, weights[:, None, :], out=scaled)
    return mean, scaled @ centred.transpose(0, 2, 1)


def _affine_rows(x: np.ndarray, scale: np.ndarray | None, shift: np.ndarray) -> np.ndarray:
    """``x (M, N, d) <- x * scale (d,) + shift (M, d)`` on every row, in place (``scale``
    None: no scaling), through a wide view: ``k`` rows side by side as ``(M, N / k, k d)``
    against ``scale`` and ``shift`` tiled k times (numpy's broadcast along a last axis of
    length d is three times slower).  ``k`` is the largest divisor of N up to 100."""
    m, n, d = x.shape
    k = _row_block(n)
    wide = np.reshape(x, (m, n // k, k * d), copy=False)  # a view (x is contiguous)
    if scale is not None:
        wide *= np.tile(scale, k)
    wide += np.tile(shift, k)[:, None, :]
    return x


@functools.cache
def _row_block(n: int) -> int:
    return max(j for j in range(1, min(n, 100) + 1) if n % j == 0) if n else 1


def _scratch(work: dict | None, name: str, shape: tuple[int, ...]) -> np.ndarray:
    """``work[name]`` if it has this shape, else a new float64 array (kept in ``work``)."""
    buf = None if work is None else work.get(name)
    if buf is None or buf.shape != shape:
        buf = np.empty(shape)
        if work is not None:
            work[name] = buf
    return buf


class ParticleBelief:
    """The :class:`uavsim.belief.Belief` of [Papaioannou2023, Sec. V-A]: M particle filters with the
    clutter likelihood, systematic resampling (and roughening) when the ESS is low, and the
    pseudo-posterior traces of Eq. (12) for the UAV's decision.

    Track loss (``loss_nats > 0``): a CUSUM [Page1954] per target of the log likelihood ratio of
    "the target is anywhere" (:func:`uavsim.sensing.uniform_loglik`) to "the target is in the predicted
    cloud" (the update's evidence), ``S <- max(0, S + log g_u - log g_cloud)``, summed over
    the sensors of a step.  A tracked target's detection takes about 5 nats off (paper
    sensor: sigma 1 deg, p_D 0.95, Lambda 1) and a missed one adds at most ``log(1 + n p_D /
    ((1 - p_D) L))`` (3.0 for one false alarm); a lost target's detection adds about as
    much.  ``S > loss_nats`` declares the track lost (:attr:`lost`): the cloud has left
    the target, and the closed loop re-seeds it (:mod:`.recovery`), which resets ``S``.
    """

    def __init__(self, rng: np.random.Generator, means: np.ndarray, covs: np.ndarray, n: int,
                 resample_threshold: float, roughening: float, names: tuple[str, ...], loss_nats: float = 0.0,
                 noise_scales: np.ndarray | None = None, scale_switch: float = 0.0, clear=None,
                 noise_shares: np.ndarray | None = None, noise_space: str = "state", route_switch: float = 0.0):
        self.rng, self.names, self.noise_space, self.route_switch = rng, names, noise_space, route_switch
        self.sens = None  # (M, k, 6, 4) each committed cluster's G_t = d x_t / d offset (motion = "commit")
        self.origins = self.nominal = None  # (M, k, 6) each committed cluster's mean at commit, and its plan's now
        self.neighbours = None  # (M, k, ROUTE_NEIGHBOURS) each committed cluster's nearest others
        self.scale = self.live = None  # (M, 4) the committed clustering's scale; (M, k) its clusters with particles
        self.threshold, self.roughening, self.loss_nats = resample_threshold, roughening, loss_nats
        particles, unrestricted = restricted_draws(rng, means, covs, n, clear)
        self.pf = ParticleFilter.from_priors(rng, means, covs, n, noise_scales, scale_switch, particles, noise_shares)
        self.notes = [f"{names[j]}: {k} of {n} prior particles not restricted to the starts a target may take "
                      f"(too few clear draws in {PRIOR_ROUNDS} rounds)" for j, k in enumerate(unrestricted) if k]
        self.cusum = np.zeros(len(means))  # (M,) nats of evidence that the cloud has lost its target

    def drain_notes(self) -> list[str]:
        """The events noted since the last call (a prior that could not be restricted)."""
        notes, self.notes = self.notes, []
        return notes

    @property
    def lost(self) -> np.ndarray:
        """(M,) bool: the targets whose evidence of loss passed ``loss_nats`` (never if 0)."""
        return (self.cusum > self.loss_nats) if self.loss_nats > 0 else np.zeros(len(self.cusum), bool)

    def predict(self, dynamics: Dynamics, controls: np.ndarray,
                split: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        self.pf.predict(self.rng, dynamics.a, dynamics.b, dynamics.q_chol, controls, split)

    def applied(self, mask: np.ndarray | None = None) -> np.ndarray:
        """The weighted mean of the ground force the particles moved by last: ``(M, 2)``
        of each cloud, or with ``mask (M, N)`` ``(M, 2, 2)`` of each half (False, True;
        an empty half's is the cloud's)."""
        if mask is None:
            return np.einsum("mn,mni->mi", self.pf.weights, self.pf.applied)
        return np.einsum("mhn,mni->mhi", cluster_weights(self.pf.weights, mask, 2)[0], self.pf.applied)

    def keep_out(self, inside) -> list[str]:
        """The targets keep out of the obstacles: the particles ``inside(positions (M, N,
        3))`` marks (``(M, N)`` bool) weigh zero, as if a measurement said where no target
        can be; the clouds are then resampled as an update's are (ESS test), so that a
        mission without scans (the no-information baseline) does not thin out.  A target
        whose every particle is inside keeps its weights, reported.  Returns event messages."""
        hit = inside(self.pf.particles[..., :3])
        if not hit.any():
            return []
        bad, _ = self.pf.update(np.where(hit, -np.inf, 0.0))
        events = [f"{self.names[j]}: every particle inside an obstacle after the prediction; weights kept"
                  for j in np.flatnonzero(bad)]
        resampled = self.pf.resample(self.rng, self.threshold, self.roughening)
        if resampled.any():
            events.append("resampled " + ", ".join(self.names[j] for j in np.flatnonzero(resampled))
                          + " (particles inside obstacles)")
        return events

    def commit(self, k: int, reference: tuple | None = None, probed: int = 0, label: np.ndarray | None = None
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Split each cloud in ``k`` clusters (:func:`clusters`), which the particles keep
        (resampling copies a particle's cluster and offset); each particle's offset is its
        ``[x, y, vx, vy]`` less its cluster's mean.  Returns each cluster's mean ``(M, k, 6)``,
        covariance ``(M, k, 6, 6)`` and weight ``(M, k)`` (an empty cluster has the cloud's
        mean and covariance and weight 0).  ``reference``: the clusters of another cloud
        (:func:`reference_clusters`), which the particles join (:func:`join_clusters`); their
        means and covariances are returned, and the offsets are from those means.  ``probed``:
        the last clusters of ``reference`` were added for routes the others miss
        (:meth:`uavsim.sim.Simulation.first_commit`); their particles may switch routes, but
        none switches to them (:meth:`_switch_routes`).  ``label (M, N)``: the reference
        cluster each particle takes instead of its nearest (:mod:`.choice`)."""
        if reference is None:
            self.pf.label = clusters(self.pf.particles, self.pf.weights, k)
            parts, mass = cluster_weights(self.pf.weights, self.pf.label, k)
            means, covs = part_moments(self.pf.particles, parts)
            scale, live = centred(self.pf.particles, self.pf.weights)[1], mass > 0
        else:
            means, covs, scale, live = reference
            self.pf.label = join_clusters(self.pf.particles, means, scale, live) if label is None else label
            mass = label_mass(self.pf.weights, self.pf.label, k)
        own = by_label(means, self.pf.label)  # (M, N, 6) each particle's cluster mean
        self.pf.offset = (self.pf.particles - own)[..., HORIZONTAL]
        self.origins, self.nominal = means.copy(), means.copy()
        self.scale, self.live = scale, live
        self.neighbours = cluster_neighbours(means, scale, live & (np.arange(live.shape[1]) < live.shape[1] - probed))
        self.sens = np.zeros((*mass.shape, 6, 4))
        self.sens[..., HORIZONTAL, np.arange(4)] = 1.0
        return means, covs, mass

    def cluster_mass(self, k: int) -> np.ndarray:
        """``(M, k)`` the weight each cluster of :meth:`commit` holds now."""
        return label_mass(self.pf.weights, self.pf.label, k)

    def predict_committed(self, dynamics: Dynamics, forces: np.ndarray, gains: np.ndarray) -> None:
        """Eq. (9a) with committed plans: particle n of cluster c moves by ``forces[:, c]
        (M, k, 3) + gains[:, c] (M, k, 3, 4) @ offset_n``, its cluster plan's force and that
        plan's response to a start moved by the particle's offset
        (:meth:`uavsim.guidance.Guidance.gains`).  The process noise goes where
        ``noise_space`` says (module docstring): to the state, or the ``[x, y, vx, vy]`` part of
        it to the start offset with the state moved by :attr:`sens` times it, or split by level.
        :attr:`sens` then steps on, ``G_{t+1} = A G_t + B K_t``, as does each cluster's plan from its
        start (:attr:`nominal`); with :attr:`route_switch` some particles then change cluster
        (:meth:`_switch_routes`)."""
        lab = self.pf.label
        q_chol, state_noise = dynamics.q_chol, None
        if self.noise_space != "state":
            nu = self.pf.noise(self.rng, np.empty(self.pf.particles.shape)) @ q_chol.T  # (M, N, 6) each level's
            in_state = np.zeros(lab.shape, bool)
            if self.noise_space == "split":  # the highest level (the only one, if one) stays in the state
                levels = self.pf.levels
                in_state = np.ones(lab.shape, bool) if levels is None else self.pf.mode == np.argmax(levels)
                state_noise = np.where(in_state[..., None], nu, 0.0)
            self._move_starts(np.where(in_state[..., None], 0.0, nu[..., HORIZONTAL]))
            q_chol = None
        own = by_label(forces, lab)  # (M, N, 3)
        own += np.einsum("mnij,mnj->mni", by_label(gains, lab), self.pf.offset)
        self.pf.predict(self.rng, dynamics.a, dynamics.b, q_chol, own)
        if state_noise is not None:
            self.pf.particles += state_noise
        self.sens = dynamics.a @ self.sens + dynamics.b @ gains
        self.nominal = self.nominal @ dynamics.a.T + forces @ dynamics.b.T
        if self.route_switch > 0:
            self._switch_routes()

    def _switch_routes(self) -> None:
        """Each particle, with chance :attr:`route_switch`, takes one of its cluster's
        :data:`ROUTE_NEIGHBOURS` nearest clusters (:func:`cluster_neighbours`, drawn alike)
        instead: its state moves from where its own cluster's plan and gains put its start now
        to where the new cluster's put it, keeping the noise it gathered, as if the target had
        taken that route from the start (a jump-Markov route model; the bearings weigh which
        fits).  A cluster added by the route probes is never switched to (:meth:`commit`): its
        route lies far from its neighbours' by construction, and a jump onto it moves a
        particle by the whole difference.

        A switch that would move a particle farther than its cloud is wide and leave it outside
        the cloud (the move's squared Mahalanobis length, and its landing point's distance from
        the cloud's weighted mean, in the cloud's weighted position covariance, both over
        :data:`SWITCH_SUPPORT`, :func:`within_spread`) is refused: the particle keeps the
        weight the bearings gave it on its old route, and a jump out of the cloud would carry
        that weight where no bearing tested it (a cluster whose model had run 500 m off took
        18% of a belief in one unseen step).  A particle whose own cluster has run off may
        jump back in however far."""
        rows, cols = np.nonzero(self.rng.random(self.pf.label.shape) < self.route_switch)
        if not rows.size:
            return
        old = self.pf.label[rows, cols]
        new = self.neighbours[rows, old, self.rng.integers(0, self.neighbours.shape[2], rows.size)]
        o_old = self.pf.offset[rows, cols]
        o_new = o_old + (self.origins[rows, old] - self.origins[rows, new])[:, HORIZONTAL]

        def model(c, o):
            return self.nominal[rows, c] + np.einsum("sij,sj->si", self.sens[rows, c], o)

        jump = model(new, o_new) - model(old, o_old)
        keep = within_spread(self.pf.particles[..., :2], self.pf.weights, rows, self.pf.particles[rows, cols, :2],
                             jump[:, :2])
        rows, cols = rows[keep], cols[keep]
        self.pf.particles[rows, cols] += jump[keep]
        self.pf.label[rows, cols], self.pf.offset[rows, cols] = new[keep], o_new[keep]

    def _move_starts(self, step: np.ndarray) -> None:
        """Each particle's start offset moves by ``step (M, N, 4)`` and its state by its
        cluster's sensitivity times that: it then flies the committed plan from its new start."""
        self.pf.particles += np.einsum("mnij,mnj->mni", by_label(self.sens, self.pf.label), step)
        self.pf.offset += step

    def halves(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The cloud in two (:func:`halves`): ``mask (M, N)`` (True: the second half), each
        half's weight ``mass (M, 2)``, mean ``(M, 2, 6)`` and covariance ``(M, 2, 6, 6)``
        (those of an empty half are the whole cloud's)."""
        mask = halves(self.pf.particles, self.pf.weights)
        parts, mass = cluster_weights(self.pf.weights, mask, 2)
        return (mask, mass, *part_moments(self.pf.particles, parts))

    def update(self, scans: list[Scan], observers: np.ndarray, sensor: BearingModel) -> list[str]:
        if not scans:  # no sensor: the prediction is the posterior
            return []
        loglik = sum(sensor.log_likelihood(s, self.pf.particles, o) for s, o in zip(scans, observers))
        bad, evidence = self.pf.update(loglik)
        events = [f"{self.names[j]}: degenerate update skipped (no particle explains the bearings)"
                  for j in np.flatnonzero(bad)]
        if self.loss_nats > 0:  # a degenerate update is as strong a sign of loss as the threshold
            against = sum(sensor.uniform_loglik(s.valid) for s in scans) - evidence
            self.cusum = np.maximum(0.0, self.cusum + np.minimum(against, self.loss_nats + 1.0))
        resampled = self.pf.resample(self.rng, self.threshold, self.roughening)
        if resampled.any():
            events.append("resampled " + ", ".join(self.names[j] for j in np.flatnonzero(resampled)))
        return events + self._collapsed()

    def _collapsed(self) -> list[str]:
        """A cloud whose weighted position spread is below :data:`COLLAPSED_M` has collapsed to
        a point (resampling copied one particle whose noise had contracted with its plan, or
        keep-out left one particle clear): it claims to know the position exactly and cannot
        recover by itself.  With track-loss detection it is declared lost (:attr:`lost`, the
        evidence set past ``loss_nats``) and re-seeded; either way an event says so."""
        cov = weighted_moments(self.pf.particles[..., :2], self.pf.weights)[1]
        spread = np.sqrt(np.trace(cov, axis1=1, axis2=2))
        rows = np.flatnonzero(spread < COLLAPSED_M)
        if self.loss_nats > 0:
            self.cusum[rows] = np.maximum(self.cusum[rows], self.loss_nats + 1.0)
        then = "declared lost" if self.loss_nats > 0 else "loss detection off (loss_nats = 0)"
        return [f"{self.names[j]}: particle cloud collapsed to a point (position spread {spread[j]:.1e} m); {then}"
                for j in rows]

    def moments(self) -> tuple[np.ndarray, np.ndarray]:
        return self.pf.moments()

    def recover(self, scans: list[Scan], observers: np.ndarray, sensor: BearingModel, world, route_field,
                share: float, discs: tuple[np.ndarray, np.ndarray]) -> list[str]:
        """Re-seed the targets declared :attr:`lost` from this step's ``scans`` taken at
        ``observers (S, 3)`` (:func:`.recovery.draw`; ``route_field(j)``: the route field to
        target j's goal; ``discs``: every target's centre ``(M, 2)`` and radius ``(M,)`` of
        where it can be, :func:`.recovery.reach`), ``share`` of their particles each
        (:meth:`reseed`).  Returns a track-loss event per target re-seeded; one without a
        bearing this step, or whose bearings all miss its disc, stays declared lost and
        waits for the next scan."""
        rows = np.flatnonzero(self.lost)
        cloud = self.pf.particles[rows]
        n = max(1, round(share * cloud.shape[1]))
        evidence = self.cusum[rows]
        fresh, ok = recovery.draw(self.rng, cloud, scans, observers, sensor, world, [route_field(j) for j in rows],
                                  rows, n, (discs[0][rows], discs[1][rows]))
        self.reseed(rows[ok], fresh[ok])
        return [f"{self.names[j]}: track lost ({e:.1f} nats against its cloud); {n} of {cloud.shape[1]} particles "
                "re-seeded along its bearings and routes" for j, e in zip(rows[ok], evidence[ok])]

    def reseed(self, rows: np.ndarray, fresh: np.ndarray) -> None:
        """Targets ``rows (L,)`` take ``fresh (L, R, 6)`` particles in place of R of their
        own: the cloud is first resampled (systematic) to ``N - R`` equally weighted
        particles, so the part still on the target keeps its share, and every particle
        then weighs ``1 / N``; the loss evidence of those targets restarts at 0.  With
        committed plans a fresh particle joins the cluster whose plan's state now
        (:attr:`nominal`) is nearest its own in ``[x, y, vx, vy]`` (:func:`join_clusters`, the
        scale of the commit), among every cluster that held particles at the commit, with no
        offset: it flies that cluster's plan.  The kept particles' clusters are those of the
        route the lost cloud wrongly followed, so a fresh particle may join one none of them
        is of (docs/results/towns.md, "A re-seed that flies the target's route")."""
        if not rows.size:  # no lost target has a ray to draw from this step
            return
        n = self.pf.particles.shape[1]
        keep = n - fresh.shape[1]
        idx = systematic_indices(self.rng, self.pf.weights[rows], keep)
        kept = np.take_along_axis(self.pf.particles[rows], idx[..., None], axis=1)
        self.pf.particles[rows] = np.concatenate([kept, fresh], axis=1)
        kept_force = np.take_along_axis(self.pf.applied[rows], idx[..., None], axis=1)
        self.pf.applied[rows] = np.concatenate([kept_force, np.broadcast_to(
            kept_force.mean(axis=1, keepdims=True), (*fresh.shape[:2], 2))], axis=1)
        kept_label = np.take_along_axis(self.pf.label[rows], idx, axis=1)
        fresh_label = (np.zeros(fresh.shape[:2], np.intp) if self.nominal is None else
                       join_clusters(fresh, self.nominal[rows], self.scale[rows], self.live[rows]))
        self.pf.label[rows] = np.concatenate([kept_label, fresh_label], axis=1)
        self.pf.offset[rows] = np.concatenate([np.take_along_axis(self.pf.offset[rows], idx[..., None], axis=1),
                                               np.zeros((*fresh.shape[:2], 4))], axis=1)
        if self.pf.mode is not None:
            self.pf.mode[rows] = np.concatenate([np.take_along_axis(self.pf.mode[rows], idx, axis=1),
                                              self.pf.draw_levels(self.rng, fresh.shape[:2])], axis=1)
        logw = self.pf.logw.copy()
        logw[rows] = -np.log(n)
        self.pf.logw = logw
        self.cusum[rows] = 0.0

    def traces(self, candidates: np.ndarray, sensor: BearingModel) -> np.ndarray:
        return pseudo_traces(candidates, self.pf.particles, self.pf.weights, sensor)

    def samples(self) -> np.ndarray:
        return self.pf.particles.copy()

    def draw(self, rng: np.random.Generator, k: int) -> np.ndarray:
        """k particles per target, each picked with probability its weight (independently)."""
        idx = inverse_cdf(self.pf.weights, rng.random((len(self.pf.weights), k)))
        return np.take_along_axis(self.pf.particles, idx[..., None], axis=1)

    def credible_level(self, truth: np.ndarray, mean: np.ndarray, cov: np.ndarray) -> np.ndarray:
        return credible_level(truth, mean, cov, self.pf.particles, self.pf.weights)
