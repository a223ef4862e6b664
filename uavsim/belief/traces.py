"""The pseudo-posterior covariance traces a belief answers the UAV with (Eq. 12).

[Papaioannou2023] Sec. V-B, Eq. (12).  For every candidate UAV position s and every
target j, the ideal (noise-free, no clutter) bearing from the predicted mean,
``z_j(s) = l(mu_j, s)`` (Eq. 12), re-weights target j's predicted particles by
``N(z_j(s); l(x_i, s), sigma^2)``; the pseudo-posterior covariance trace follows from
weighted moments (Eq. 11).  :meth:`uavsim.belief.Belief.traces` answers with
:func:`pseudo_traces` (particles) or :func:`gaussian_traces` (pseudo-linear filters); the
UAV's rule that goes to the least summed trace, Eq. (13), is
:func:`uavsim.uav.grid.decide`.

Vectorised over candidates x targets x particles.  The residual bearing is computed
exactly as ``atan2(d_mu x d_i, d_mu . d_i)`` (the signed angle between the directions to
the mean and to the particle; no wrap needed) and squared, by
:func:`uavsim.estimators.angles.atan2_into` (a polynomial where numpy's float32 arctan2 is not
vectorised).  The bulk arithmetic runs in float32 on particles centred at their predicted
mean, so the moment sums stay well conditioned: the traces agree with a float64 loop to
~1e-5 relative (see the tests).
"""

from __future__ import annotations

import numpy as np

from ..estimators.angles import atan2_into
from ..sensing import BearingModel, MeasurementModel

BLOCK_ELEMENTS = 1 << 16  # candidate x target x particle entries per block: 256 kB float32 arrays stay in L2
DECISION_PARTICLES = 1000  # per target: the systematic subsample of :func:`model_traces`
SIGHT_CELLS = 32  # per target: the cells of :func:`sight_cells`, one line of sight tested to each
SIGHT_ACROSS = 4  # cells across a cloud's principal axis, in each of its SIGHT_CELLS / 4 strips along it
MIN_RANGE_M = 1.0
"""The range floor of :func:`gaussian_traces` (m).  Within it the linearisation says nothing
useful (the bearing's gradient grows as ``1 / r``) and right above a mean it is undefined;
floored, ``|H| = r / MIN_RANGE_M^2`` falls to 0 there, so a candidate right above a target's
mean scores as no measurement instead of stopping the run.  Our choice: the paper's beliefs
are particles, whose traces need no floor."""


def pseudo_traces(candidates: np.ndarray, particles: np.ndarray, weights: np.ndarray,
                  sensor: MeasurementModel) -> np.ndarray:
    """``tr(Sigma~_j(s))`` for every candidate and target, Eq. (12) then Eq. (11).

    A bearing sensor takes the fast path below (:func:`bearing_traces`), under line of
    sight with each cell of a cloud detected or not from each candidate
    (:func:`sight_cells`); any other measurement model :func:`model_traces`.

    Parameters
    ----------
    candidates : (C, >=2) UAV positions; particles : (M, N, 6) predicted particles;
    weights : (M, N) their weights (rows sum to 1); sensor : the measurement model.

    Returns
    -------
    (C, M) float64 traces.
    """
    if not isinstance(sensor, BearingModel):
        return model_traces(candidates, particles, weights, sensor)
    if not sensor.line_of_sight:
        return bearing_traces(candidates, particles, weights, sensor.sigma)
    n = particles.shape[1]
    order, k = sight_cells(particles, weights)
    particles, weights = _gather(particles, order), _gather(weights, order)
    weights[:, n:] = 0.0  # the copies that fill the last cells up
    return bearing_traces(candidates, particles, weights, sensor.sigma,
                          cell_detection(candidates, particles, weights, k, sensor))


def sight_cells(particles: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, int]:
    """The cells the decision tests line of sight to (:func:`cell_detection`).

    Each target's particles ``(M, N, 6)`` (weights ``(M, N)``) are split into k cells of
    L particles: :data:`SIGHT_CELLS` / :data:`SIGHT_ACROSS` strips across the cloud's
    principal axis, each cut in :data:`SIGHT_ACROSS` along the other (fewer cells for
    clouds of fewer particles).  ``k L >= N``: the last particle fills the last cells up
    (the caller gives those copies weight 0).

    Returns
    -------
    order : (M, k L) the particles cell by cell: cell j is positions ``j L`` to
    ``(j + 1) L``; k : the number of cells.
    """
    m, n, _ = particles.shape
    across = min(SIGHT_ACROSS, n)
    strips = max(min(SIGHT_CELLS, n) // across, 1)
    k = strips * across
    length = -(-n // k)
    u, v = _principal(particles[..., :2], weights)  # (M, N) each
    strip_of = np.empty((m, n), dtype=np.intp)
    np.put_along_axis(strip_of, np.argsort(u, axis=1), (np.arange(n) // (across * length))[None], axis=1)
    span = np.ptp(v, axis=1, keepdims=True)
    order = np.argsort(strip_of + 0.5 * (v - v.min(axis=1, keepdims=True)) / np.where(span > 0, span, 1.0), axis=1)
    return np.concatenate([order, np.repeat(order[:, -1:], k * length - n, axis=1)], axis=1), k


def cell_detection(candidates: np.ndarray, particles: np.ndarray, weights: np.ndarray, k: int,
                   sensor: BearingModel) -> np.ndarray:
    """``(M, C, k)`` float32 detection probability of each of the k cells of
    :func:`sight_cells` (particles ``(M, k L, >=3)`` and weights cell by cell) from each
    candidate: ``p_D``, or 0 where the line of sight to the cell's particle nearest its
    weighted mean is blocked.

    The whole cell takes that verdict: exact for a target no shadow's edge crosses (every
    cell gets one verdict from a candidate); a particle in a cell a shadow's edge crosses
    may take the wrong side.  It keeps the segment tests at ``C M k`` (tested as fans
    from the candidates: :meth:`~uavsim.sensing.BearingModel.visible`), and the particles
    of a cell share one detection probability, so none is formed per particle."""
    m = len(particles)
    x, y, w = (np.ascontiguousarray(a).reshape(m, k, -1) for a in (particles[..., 0], particles[..., 1], weights))
    total = w.sum(axis=2, keepdims=True)  # (M, k, 1)
    some = total > 0  # else the cell's plain mean
    mx = np.where(some, (w * x).sum(axis=2, keepdims=True) / np.where(some, total, 1.0), x.mean(axis=2, keepdims=True))
    my = np.where(some, (w * y).sum(axis=2, keepdims=True) / np.where(some, total, 1.0), y.mean(axis=2, keepdims=True))
    nearest = ((x - mx) ** 2 + (y - my) ** 2).argmin(axis=2)  # (M, k)
    points = particles[np.arange(m)[:, None], nearest + np.arange(k) * x.shape[2], :3]  # (M, k, 3)
    seen = sensor.visible(points[:, None], np.asarray(candidates, float)[None, :, None, :3])  # (M, C, k)
    return seen.astype(np.float32) * np.float32(sensor.p_detect)


def _principal(xy: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(u, v)``: positions ``xy (M, N, 2)`` along and across each cloud's principal axis
    (of its weighted covariance), about its weighted mean; ``(M, N)`` float32 each (they
    only sort the particles into cells)."""
    x, y, w = xy[..., 0].astype(np.float32), xy[..., 1].astype(np.float32), weights.astype(np.float32)
    x -= (w * x).sum(axis=1, keepdims=True)
    y -= (w * y).sum(axis=1, keepdims=True)
    wx, wy = w * x, w * y
    cov = np.stack([(wx * x).sum(axis=1), (wx * y).sum(axis=1), (wy * y).sum(axis=1)], -1).astype(np.float64)
    axes = np.linalg.eigh(cov[:, [0, 1, 1, 2]].reshape(-1, 2, 2))[1].astype(np.float32)  # (M, 2, 2), ascending
    return x * axes[:, :1, 1] + y * axes[:, 1:, 1], x * axes[:, :1, 0] + y * axes[:, 1:, 0]


def _gather(x: np.ndarray, order: np.ndarray) -> np.ndarray:
    """``x (M, N, ...)`` with each row's entries taken in ``order (M, N')``: ``(M, N', ...)``."""
    m, n = x.shape[:2]
    return x.reshape(m * n, *x.shape[2:])[(order + n * np.arange(m)[:, None]).ravel()].reshape(
        order.shape + x.shape[2:])


def model_traces(candidates: np.ndarray, particles: np.ndarray, weights: np.ndarray,
                 sensor: MeasurementModel, keep: int = DECISION_PARTICLES) -> np.ndarray:
    """Eq. (12)-(11) for any measurement model, and with the detection probability at each
    particle under line of sight.

    Eq. (12) re-weights particle i by ``N(h(mu, s); h(x_i, s), R)``
    (:meth:`~uavsim.sensing.MeasurementModel.pseudo_loglik`).  Under line of sight the
    scan holds the target's measurement only with the probability ``p_i(s)`` of
    :meth:`~uavsim.sensing.BearingModel.detection` (0 behind a building), so the expected
    trace mixes both outcomes: ``P_d tr(Sigma_det) + (1 - P_d) tr(Sigma_miss)``, with
    ``P_d = sum w_i p_i``, ``Sigma_det`` the moments of the weights ``w_i p_i N(...)`` and
    ``Sigma_miss`` those of ``w_i (1 - p_i)`` (a miss tells the filter the target is
    probably hidden).  Without line of sight the detection is taken for granted, as in
    the paper.  Clouds of more than ``keep`` (:data:`DECISION_PARTICLES`) are first thinned
    to that many by deterministic systematic resampling (equal weights), which bounds the
    segment tests to ``C M keep``.

    Returns (C, M) float64 traces.
    """
    particles, weights = _thinned(particles, weights, keep)
    mean = np.einsum("mn,mni->mi", weights, particles)  # (M, 6)
    centred = particles - mean[:, None, :]
    loglik = sensor.pseudo_loglik(candidates, particles, mean)  # (M, C, N)
    lik = np.exp(loglik - loglik.max(axis=2, keepdims=True))
    det = weights[:, None, :] * lik
    if not sensor.line_of_sight:
        return _weighted_trace(det, centred).T
    p = sensor.detection(particles[:, None, :, :3], np.asarray(candidates, float)[None, :, None, :3])  # (M, C, N)
    det = det * p
    miss = weights[:, None, :] * (1.0 - p)
    p_det = np.einsum("mn,mcn->mc", weights, p)
    return (p_det * _weighted_trace(det, centred) + (1.0 - p_det) * _weighted_trace(miss, centred)).T


def _weighted_trace(w: np.ndarray, centred: np.ndarray) -> np.ndarray:
    """``(M, C)`` trace of the covariance of ``centred (M, N, d)`` under weights ``w (M, C, N)``
    (normalised here; 0 where a row's weights are all 0)."""
    total = w.sum(axis=2)
    safe = np.where(total > 0, total, 1.0)
    first = (w @ centred) / safe[..., None]  # (M, C, d)
    second = (w @ (centred**2).sum(-1)[..., None])[..., 0] / safe
    return np.where(total > 0, second - (first**2).sum(-1), 0.0)


def _thinned(particles: np.ndarray, weights: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """At most ``k`` equally weighted particles per target, by systematic resampling with
    the fixed offset 1/2 (deterministic: the decision draws no random numbers)."""
    m, n, _ = particles.shape
    if n <= k:
        return particles, weights
    idx = inverse_cdf(weights, ((np.arange(k) + 0.5) / k)[None, :])  # (M, k)
    return np.take_along_axis(particles, idx[..., None], axis=1), np.full((m, k), 1.0 / k)


def inverse_cdf(weights: np.ndarray, u: np.ndarray) -> np.ndarray:
    """``(R, k)`` indices of the positions ``u`` (broadcast to ``(R, k)``, in [0, 1)) in each
    row's cumulative ``weights (R, N)``: the particle each position picks (resampling,
    thinning, draws).  Rows are searched at once by offsetting row r's cumulative weights
    by r."""
    r, n = weights.shape
    cum = np.cumsum(weights, axis=1)
    cum /= cum[:, -1:]
    offsets = np.arange(r)[:, None]
    at = np.searchsorted((cum + offsets).ravel(), (u + offsets).ravel(), side="right")
    return np.minimum(at.reshape(r, -1) - offsets * n, n - 1)


def bearing_traces(candidates: np.ndarray, particles: np.ndarray, weights: np.ndarray, sigma: float,
                   detect: np.ndarray | None = None) -> np.ndarray:
    """:func:`pseudo_traces` for a bearing sensor.

    Parameters
    ----------
    candidates : (C, >=2) UAV positions; particles : (M, N, 6) predicted particles;
    weights : (M, N) their weights (rows sum to 1); sigma : bearing noise std (rad);
    detect : (M, C, k) under line of sight: the particles are in k cells of ``N / k``
    (:func:`sight_cells`), cell j detected from candidate c with probability
    ``detect[:, c, j]`` (:func:`cell_detection`); or None: the detection is taken for
    granted, as in Eq. (12).  With it the expected trace mixes both outcomes,
    ``P_d tr(Sigma_det) + (1 - P_d) tr(Sigma_miss)`` (:func:`model_traces`).

    Returns
    -------
    (C, M) float64 traces.

    Notes
    -----
    The particles are taken in blocks of about ``BLOCK_ELEMENTS / (C M)`` (whole cells
    under line of sight) so the ``(M, C, block)`` working arrays stay in cache and the time
    grows linearly in N.  Each block's sums are taken relative to its own best-aligned
    particle and rescaled to the best of all when the blocks are added (in float64).
    """
    mean = (weights[:, None, :] @ particles)[:, 0]  # (M, 6)
    rows = _particle_rows(particles, mean)  # (M, 8, N) float32: p_x, p_y, 1, p_z, p_v (3), |p|^2
    d = (mean[:, None, :2] - candidates[None, :, :2]).astype(np.float32)  # (M, C, 2): d_mu = mu - s
    # With d_i = d_mu + p_i:  d_mu x d_i = dx py - dy px  and  d_mu . d_i = dx px + dy py + |d_mu|^2
    # (the cross terms cancel): rank-2 and rank-3 products with the rows (p_x, p_y, 1).
    a_cross = np.stack([-d[..., 1], d[..., 0]], -1)  # (M, C, 2)
    a_dot = np.concatenate([d, (d**2).sum(-1, keepdims=True)], -1)  # (M, C, 3)
    feats = rows * weights.astype(np.float32)[:, None, :]  # w_i (p_x, p_y, 1, ...): the sums' features
    m, n = weights.shape
    block = max(1, BLOCK_ELEMENTS // max(m * len(candidates), 1))
    if detect is not None:  # whole cells of L particles a block
        length = n // detect.shape[2]
        block = length * max(1, round(block / length))
    sums, lows = [], []
    for lo in range(0, n, block):
        part = slice(lo, lo + block)
        s_b, low = _block_sums(a_cross @ rows[:, :2, part], a_dot @ rows[:, :3, part], feats[:, :, part], sigma,
                               None if detect is None else detect[:, :, lo // length:(lo + block) // length])
        sums.append(s_b)
        lows.append(low)
    lows = np.array(lows, dtype=np.float64)  # (B, M, C) least squared residual per block
    scale = np.exp(-0.5 / sigma**2 * (lows - lows.min(axis=0)))  # each block relative to the best
    total = np.einsum("bmc,bmck->mck", scale, np.array(sums, dtype=np.float64))  # (M, C, 8) in rows' order
    if detect is None:  # Eq. (12) as published: every weight sum is positive
        w0, w1 = total[..., 2], total[..., [0, 1, 3, 4, 5, 6]]
        return (total[..., 7] / w0 - (w1**2).sum(-1) / w0**2).T
    per_cell = feats.reshape(m, 8, detect.shape[2], length).sum(axis=3).astype(np.float64)  # (M, 8, k)
    miss = (1.0 - detect.astype(np.float64)) @ per_cell.transpose(0, 2, 1)  # (M, C, 8) under w_i (1 - p_i)
    p_miss = miss[..., 2]  # 1 - P_d
    return ((1.0 - p_miss) * _trace_of_sums(total) + p_miss * _trace_of_sums(miss)).T


def _trace_of_sums(total: np.ndarray) -> np.ndarray:
    """``(M, C)`` covariance trace from weighted sums ``(M, C, 8)`` in the rows' order
    (:func:`_particle_rows`); 0 where the weights sum to 0 (a cloud wholly hidden, or
    wholly seen for the miss), and no overflow where they sum to almost 0."""
    w0, w2 = total[..., 2], total[..., 7]
    w1 = total[..., [0, 1, 3, 4, 5, 6]]
    safe = np.where(w0 > 0, w0, 1.0)
    return np.where(w0 > 0, w2 / safe - ((w1 / safe[..., None]) ** 2).sum(-1), 0.0)


def _particle_rows(particles: np.ndarray, mean: np.ndarray) -> np.ndarray:
    """``(M, 8, N)`` float32 rows ``p_x, p_y, 1, p_z, p_vx, p_vy, p_vz, |p|^2`` of the
    particles centred at ``mean`` (subtracted in float64, stored in float32)."""
    m, n, _ = particles.shape
    xt = particles.transpose(0, 2, 1)  # (M, 6, N) view
    rows = np.empty((m, 8, n), np.float32)
    np.subtract(xt[:, :2], mean[:, :2, None], out=rows[:, :2], casting="same_kind")
    rows[:, 2] = 1.0
    np.subtract(xt[:, 2:], mean[:, 2:, None], out=rows[:, 3:7], casting="same_kind")
    np.einsum("mdn,mdn->mn", rows[:, :2], rows[:, :2], out=rows[:, 7])
    rows[:, 7] += np.einsum("mdn,mdn->mn", rows[:, 3:7], rows[:, 3:7])
    return rows


def _block_sums(cross: np.ndarray, dot: np.ndarray, feats: np.ndarray, sigma: float,
                detect: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """One block of particles: ``cross, dot (M, C, B)``, weighted features ``(M, 8, B)``.
    Returns the sums ``(M, C, 8)`` weighted by ``exp(-(r^2 - r_min^2) / 2 sigma^2)`` (times
    the detection ``detect (M, C, g)`` of the block's g cells of ``B / g`` particles if
    given) and ``r_min^2 (M, C)``, the block's least squared residual."""
    expo = atan2_into(cross, dot, squared=True)  # (M, C, B): (l(x_i, s) - l(mu, s))^2
    low = expo.min(axis=2)
    expo -= low[..., None]  # the best-aligned particle gets exp(0): no underflow
    expo *= np.float32(-0.5 / sigma**2)
    lik = np.exp(expo, out=expo)
    if detect is None:
        return lik @ feats.transpose(0, 2, 1), low
    if detect.shape[2] == 1:  # one cell: its detection scales the block's sums
        return (lik @ feats.transpose(0, 2, 1)) * detect, low
    cells = lik.reshape(detect.shape + (-1,))  # a view: (M, C, g, B / g)
    cells *= detect[..., None]
    return lik @ feats.transpose(0, 2, 1), low


def gaussian_traces(candidates: np.ndarray, means: np.ndarray, covs: np.ndarray, sensor: MeasurementModel,
                    min_range: float = MIN_RANGE_M, info_factor: float = 1.0,
                    detect: np.ndarray | None = None) -> np.ndarray:
    """Eq. (12)-(13) for Gaussian beliefs (the pseudo-linear filters, the lookahead): the
    trace after a noise-free measurement linearised at the mean,
    ``tr(P) - tr(P H^T (H P H^T + R / info_factor)^-1 H P)``, ``H`` the model's Jacobian
    (for bearings ``(dy, -dx) / r^2``, ``r`` floored at ``min_range``), and with a
    detection probability ``detect (..., C, M)`` the expected trace
    ``tr(P) - detect tr(...)`` (a miss leaves the prediction).

    candidates (..., C, >=2); means (M, >=2); covs (..., M, n, n), x and y first (leading
    dimensions broadcast).  Returns (..., C, M)."""
    h = np.swapaxes(sensor.jacobian(means, candidates, min_range), -3, -4)  # (..., C, M, d, 2)
    ph = np.einsum("...mij,...cmdj->...cmid", covs[..., :2], h)  # (..., C, M, n, d): P H^T
    s = np.einsum("...cmdi,...cmie->...cmde", h, ph[..., :2, :]) + sensor.noise_cov / info_factor
    if s.shape[-1] == 1:  # one value per measurement (bearings): a division
        gain = np.sum(ph[..., 0] ** 2, -1) / s[..., 0, 0]
    else:
        gain = np.einsum("...id,...de,...ie->...", ph, np.linalg.inv(s), ph)
    if detect is not None:
        gain = gain * detect
    return np.trace(covs, axis1=-2, axis2=-1)[..., None, :] - gain
