"""What a Monte-Carlo study measures: RMSE, the no-information ratio, NEES consistency.

* **RMSE** ([Papaioannou2023] Sec. VI-B): at step t,
  ``eps_t = sqrt(mean_n |x^pos_hat_t(n) - x^pos_t(n)|^2)`` over the N trials, (x, y)
  positions, per target; studies average it over the targets.
* **No-information ratio**: a UAV policy's time-averaged RMSE over that of the same filter
  without any measurement on the same trials (common random numbers).  Below 1 the
  bearings help; a number that would be the same with the sensor off is not a tracking
  result.  The paired t-statistic is over the per-trial mean squared errors.
* **NEES** ([BarShalom2001, Sec. 5.4.2]): ``e' P^-1 e`` of the posterior
  mean error e against the posterior covariance P.  For a consistent estimator it is
  chi-square with d degrees of freedom; the average of n independent values (trials x
  targets) lies in ``[chi2_{0.025}(n d), chi2_{0.975}(n d)] / n`` with probability 0.95.
* **Credible level** of the truth: the belief's probability of lying closer to its mean
  than the truth does (in the Mahalanobis distance of its covariance, position only):
  ``u = sum_n w_n [d(x_n) < d(x_true)]`` for particles, the chi-square(2) cdf of the NEES
  for a Gaussian belief.  Whatever the belief's shape, a calibrated belief (the truth a
  draw from it) gives u uniform on [0, 1]: mean 0.5 and 5% of truths above 0.95.  The
  NEES band assumes chi-square values: a calibrated heavy-tailed belief (the covariance
  set by its tails, most truths in its core) has the right mean NEES only on average, with
  most step averages below the band and a few far above; the level's band holds for any
  shape.  The *beliefs' band* (:func:`belief_band`) is the NEES band for the beliefs as they
  are: the average's spread taken from NEES values of states drawn from the beliefs, so a
  calibrated filter is inside it at about its level whatever the beliefs' shape.
"""

from __future__ import annotations

import numpy as np

POS = (0, 1)  # (x, y): the position error of Sec. VI-B
STATE = (0, 1, 2, 3, 4, 5)  # the full state [p, v]


def nees(err: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """``e' P^-1 e`` for errors ``(..., d)`` and covariances ``(..., d, d)``; shape ``(...)``;
    never negative, never NaN.

    A covariance that is not numerically positive definite (a collapsed particle set: its
    least eigenvalue within ``d eps`` of its largest, or below 0 by rounding) takes the
    pseudo-inverse through its eigen-decomposition, those directions left out: the error
    in the directions the filter is sure of is then not counted, which the chi-square band
    of the average will show as too small a NEES.  (A plain solve there gave values of
    -1e42 from an indefinite rounding of a collapsed cloud.)"""
    err = np.asarray(err, float)
    cov = np.asarray(cov, float)
    w, v = np.linalg.eigh(cov)
    tol = w[..., -1:] * cov.shape[-1] * np.finfo(float).eps
    sure = w[..., 0] > tol[..., 0]
    out = np.empty(err.shape[:-1])
    if sure.any():
        e = err[sure]
        out[sure] = np.einsum("...i,...i->...", e, np.linalg.solve(cov[sure], e[..., None])[..., 0])
    if not sure.all():
        proj = np.einsum("...ji,...j->...i", v[~sure], err[~sure])  # the error in the eigenbasis
        keep = w[~sure] > tol[~sure]
        out[~sure] = np.where(keep, proj**2 / np.where(keep, w[~sure], 1.0), 0.0).sum(-1)
    return out


def state_nees(mean: np.ndarray, cov: np.ndarray, truth: np.ndarray, dims=POS) -> np.ndarray:
    """NEES over the state components ``dims`` for means ``(M, 6)``, covariances
    ``(M, 6, 6)`` and true states ``(M, 6)``; shape ``(M,)``."""
    d = np.asarray(dims)
    return nees(mean[:, d] - truth[:, d], cov[:, d[:, None], d])


def draws_nees(mean: np.ndarray, cov: np.ndarray, draws: np.ndarray, dims=POS) -> np.ndarray:
    """``(M, k)`` NEES over ``dims`` of ``draws (M, k, 6)`` against means ``(M, 6)`` and
    covariances ``(M, 6, 6)`` (:func:`state_nees` for k states per target)."""
    d = np.asarray(dims)
    block = cov[:, d[:, None], d][:, None]
    return nees(draws[..., d] - mean[:, None, d], np.broadcast_to(block, (*draws.shape[:2], *block.shape[2:])))


def nees_band(n: int, dof: int, level: float = 0.95) -> tuple[float, float]:
    """Two-sided ``level`` band of the average of n independent chi-square(dof) values."""
    a = (1.0 - level) / 2.0
    from scipy import stats  # here, not at the top: the beliefs import this module, the mission reader them

    return float(stats.chi2.ppf(a, n * dof) / n), float(stats.chi2.ppf(1.0 - a, n * dof) / n)


def belief_band(n: int, dof: int, variance: np.ndarray, level: float = 0.95) -> tuple[np.ndarray, np.ndarray]:
    """Two-sided ``level`` band of the average of n independent NEES values of mean ``dof``
    (any calibrated belief's) and variance ``variance`` (one per step, ``(steps,)``): the
    scaled chi-square ``c chi2(nu)`` of the same two moments [Satterthwaite1946],
    ``c = variance / (2 dof n)``, ``nu = dof / c``.  Chi-square values (variance ``2 dof``)
    give :func:`nees_band`'s band; heavier tails a wider one, on both sides."""
    a = (1.0 - level) / 2.0
    from scipy import stats

    c = np.maximum(np.asarray(variance, float), 1e-12) / (2.0 * dof * n)
    return c * stats.chi2.ppf(a, dof / c), c * stats.chi2.ppf(1.0 - a, dof / c)


def rmse_per_target(err2: np.ndarray) -> np.ndarray:
    """``(M, steps)`` RMSE from squared position errors ``(trials, steps, M)``."""
    return np.sqrt(err2.mean(axis=0)).T


def paired_t(a: np.ndarray, b: np.ndarray) -> float:
    """Paired t-statistic of ``b - a`` over trials (positive: a is smaller); 0 for one trial."""
    diff = np.asarray(b, float) - np.asarray(a, float)
    if len(diff) < 2:
        return 0.0
    sd = diff.std(ddof=1)
    return float(diff.mean() / (sd / np.sqrt(len(diff)))) if sd > 0 else 0.0


def consistency(values: np.ndarray, dof: int, level: float = 0.95, reference: np.ndarray | None = None) -> dict:
    """Per-step average NEES of ``values (trials, steps, M)``, its band and the share of
    steps inside it (JSON-ready).

    The band is the chi-square one: a *Gaussian* belief whose covariance is right has its
    average inside at ``level`` of steps.  A particle belief is not Gaussian (a bearing's
    banana, a cloud split between two streets): the NEES of a truth that follows it
    exactly still averages ``dof``, but with heavier tails, so its per-step average leaves
    the band more often.  ``reference (trials, steps, M, draws)``: the NEES of states drawn
    from the beliefs themselves (truths a calibrated filter with these beliefs would see);
    then ``"calibrated"`` holds their per-step average (over the draws too) and the share of
    steps inside the same band, for each draw as one campaign, averaged over the draws,
    with the least and most of them: what the filter's own share would be if it were
    calibrated.  And ``"belief_band"`` tests the filter against its beliefs' own shape: each
    step's band for the average of n values whose variance is the reference's about
    ``dof`` (:func:`belief_band`), the filter's share of steps inside, below and above it,
    and the calibrated draws' share inside (about ``level`` when the band is right)."""
    trials, _, m = values.shape
    lo, hi = nees_band(trials * m, dof, level)
    mean = values.mean(axis=(0, 2))
    out = {"dof": dof, "mean": mean.tolist(), "band": [lo, hi], "level": level,
           "inside": float(np.mean((mean >= lo) & (mean <= hi))),
           "below": float(np.mean(mean < lo)), "above": float(np.mean(mean > hi))}
    if reference is not None:
        each = reference.mean(axis=(0, 2))  # (steps, draws)
        share = ((each >= lo) & (each <= hi)).mean(axis=0)  # (draws,)
        out["calibrated"] = {"mean": each.mean(axis=1).tolist(), "inside": float(share.mean()),
                             "inside_range": [float(share.min()), float(share.max())], "draws": int(share.size)}
        blo, bhi = belief_band(trials * m, dof, ((reference - dof) ** 2).mean(axis=(0, 2, 3)), level)
        out["belief_band"] = {"band": np.column_stack([blo, bhi]).tolist(),
                              "inside": float(np.mean((mean >= blo) & (mean <= bhi))),
                              "below": float(np.mean(mean < blo)), "above": float(np.mean(mean > bhi)),
                              "calibrated_inside": float(((each >= blo[:, None]) & (each <= bhi[:, None])).mean())}
    return out


def credible_level(truth: np.ndarray, mean: np.ndarray, cov: np.ndarray, particles: np.ndarray | None = None,
                   weights: np.ndarray | None = None) -> np.ndarray:
    """``(M,)`` credible level of the true positions ``truth (M, >=2)`` (module docstring):
    for particles ``(M, N, >=2)`` with ``weights (M, N)`` their weighted share closer to
    the mean ``(M, >=2)`` than the truth in the metric of ``cov (M, >=2, >=2)`` (position
    block); without particles, the chi-square(2) cdf of the NEES, ``1 - exp(-NEES / 2)``."""
    p = np.asarray(POS)
    inv = np.linalg.pinv(cov[:, p[:, None], p])
    e = truth[:, p] - mean[:, p]
    d_true = np.einsum("mi,mij,mj->m", e, inv, e)
    if particles is None:
        return -np.expm1(-0.5 * d_true)
    x = particles[..., p] - mean[:, None, p]
    d = np.einsum("mni,mij,mnj->mn", x, inv, x)
    return (weights * (d < d_true[:, None])).sum(axis=1)


EDGE = 1e-9  # a credible level within this of 0.95 is the region's edge, inside: k / N summed in
# another order (another CPU's SIMD width) lands either side of 0.95 by 1e-16


def calibration(levels: np.ndarray, level: float = 0.95) -> dict:
    """Per-step mean credible level of ``levels (trials, steps, M)``, its ``level`` band for
    a calibrated belief (u uniform: mean 1/2, variance 1/12 over n = trials x M values,
    normal approximation), the share of steps inside it, and the share of target-steps
    whose truth lies outside the belief's 95% region (5% if calibrated; JSON-ready)."""
    trials, _, m = levels.shape
    from scipy import stats

    half = stats.norm.ppf(0.5 + level / 2) * np.sqrt(1.0 / (12.0 * trials * m))
    mean = levels.mean(axis=(0, 2))
    return {"mean": mean.tolist(), "band": [0.5 - half, 0.5 + half], "level": level,
            "inside": float(np.mean(np.abs(mean - 0.5) <= half)), "outside_95": float(np.mean(levels > 0.95 + EDGE))}
