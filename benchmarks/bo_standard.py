"""The standard bearings-only benchmark: every library method and the field's strong baselines.

    python benchmarks/bo_standard.py [--runs 500] [--seed 1] [--json docs/data/bo-standard.json]

Three scenarios of the kind bearings-only papers compare on (our choice of numbers, written
here; the field's classic is an ownship that turns once so the range becomes observable):

* ``5km``: the target about 5 km away at bearing 045 deg, 3 m/s on course 135 deg; the
  ownship at 5 m/s heads west for 16 scans, then north for 16 (it manoeuvres once, and
  never closes on the target: a pass within a few hundred metres would make the bound's
  expected information that of the rare close runs); one bearing a minute, sigma 1.5 deg,
  32 scans.
* ``10km``: the same geometry at 10 km, the target 5 m/s, sigma 2 deg.
* ``manoeuvre``: the 5 km scenario, but the target turns 90 deg to starboard (its velocity
  rotated clockwise) on arriving at scan 16, where the ownship turns too: it moves the
  minute before on its old velocity.

The truth of run r is drawn from the prior every method is given (``SeedSequence(seed)
.spawn(runs)[r]``), ``N(m0, P0)``: the nominal state, 1 km (10 km: 2 km) along the first line
of sight, 300 m (600 m) across it, 2 m/s in each velocity; it then moves at constant
velocity (with the one turn in ``manoeuvre``), no process noise.  The bound is the Bayesian
CRLB of that truth: ``J_k = F_k^-T J_{k-1} F_k^-1 + E[H_k^T H_k] / sigma^2``, ``J_0 = P0^-1``,
the expectation over the runs' own truths; no process noise (the truth has none).  ``F_k``
is the truth's transition: the constant-velocity one, and at the turn the turn after it.
The turn is a known linear map of the state, so in ``manoeuvre`` this is the bound of an
estimator told the manoeuvre (its time and its angle): no method here is, so it is a valid
but loose bound for them; the bound of an estimator that must detect the turn would need a
model of when and how the target turns (a switching-model bound), which is a choice of
ours and not a property of the scenario.

Methods, each over all runs at once: the no-update control (the prior predicted), the
library's IV-, BC- and UB-PLKF ([Huang2021]; a small process noise, q = 1e-5 m^2/s^3),
PL-MMSE ([Li2022], Gaussian noise), batch ML by damped Newton and by polished NRPSO
([Oh2021]; the final scan's state from the fitted track; it uses no prior); and four
baselines written here:

* a cubature Kalman filter (CKF, Arasaratnam and Haykin 2009);
* a regularised particle filter (RPF, Musso et al. 2001; 4000 particles in single
  precision, each run resampled systematically when its sample size falls below half,
  Gaussian kernel on the weighted covariance);
* a range-parameterised EKF (RP-EKF; Peach 1995, Arulampalam and Ristic 2000): 6 EKFs
  whose ranges are the centres of 6 geometric cells of the prior's range interval, its
  mean +- 3 std along the first line of sight (2 to 8 km; 4 to 16 km), with each cell's
  spread as range std (the cell's width / sqrt 12: 7 % of the range for every filter);
  across the line of sight and in velocity each has the prior's P0, and its weight starts
  as the prior's mass in its cell (the other methods' prior, not a log-uniform one).
  Each is an EKF with the CKF's process noise; the weights follow each filter's bearing
  likelihood; the estimate is the weighted mixture's mean and covariance;
* an interacting multiple model (IMM, Blom and Bar-Shalom 1988) of two CKFs: constant
  velocity (q = 1e-5) and a manoeuvre mode (q = 0.15 m^2/s^3: 3 m/s a scan in each velocity,
  what a 90 deg turn at 3 m/s changes), switching from CV with 0.03 a scan (a turn a track)
  and back with 0.9 (a turn lasts a scan).  With a symmetric 0.95/0.05 switching half the
  time is spent in the manoeuvre mode and the range is lost (its velocity noise drowns the
  ownship's one turn).

Reported per method: the final scan's position RMSE, its ratio to the bound's, the share
of lost tracks (a final error above a quarter of the target's true range), the mean NEES
of the final position (dof 2) where the method has a covariance, the seconds per run, and
for the recursive methods the position RMSE after every scan (the docs' curves; a batch
fit uses every scan at once, so it has only the last).
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass

import numpy as np
from harness import parser, run

from uavsim import metrics
from uavsim.estimators import BatchTMA, convert
from uavsim.estimators.plkf import PseudoLinearKF, cv_model
from uavsim.estimators.plkf import predict as plkf_predict
from uavsim.estimators.plmmse import UPDATES as PLMMSE_UPDATES
from uavsim.estimators.plmmse import GaussianMixture
from uavsim.sensing import bearing_gradients, wrap_angle

DT, SCANS, Q_PSD = 60.0, 32, 1e-5
LOST = 0.25  # a track is lost when its final error exceeds this share of the target's range
PARTICLES = 4000
TURN_SCAN = 16  # the manoeuvring target's velocity is turned on arrival at this scan
BANK = 6  # the RP-EKF's filters
Q_MANOEUVRE = 0.15  # the IMM's manoeuvre mode (m^2/s^3): 3 m/s a scan in each velocity, a 90 deg turn's change
SWITCH = np.array([[0.97, 0.03], [0.9, 0.1]])  # the IMM's modes (CV, manoeuvre) a scan: a turn a track, lasting a scan


@dataclass(frozen=True)
class Scenario:
    name: str
    range_m: float
    speed: float
    course_deg: float
    sigma_deg: float
    along_m: float  # prior std along the first line of sight
    across_m: float  # ... and across it
    turn_deg: float = 0.0  # the target's course change at TURN_SCAN (clockwise); 0: constant velocity


SCENARIOS = (Scenario("5km", 5000.0, 3.0, 135.0, 1.5, 1000.0, 300.0),
             Scenario("10km", 10000.0, 5.0, 135.0, 2.0, 2000.0, 600.0),
             Scenario("manoeuvre", 5000.0, 3.0, 135.0, 1.5, 1000.0, 300.0, turn_deg=90.0))


def ownship() -> np.ndarray:
    """``(K, 2)`` observer positions: 5 m/s west for 16 scans, then north."""
    v = np.where(np.arange(SCANS)[:, None] < 16, [-5.0, 0.0], [0.0, 5.0])
    return np.vstack([[0.0, 0.0], np.cumsum(v[:-1] * DT, axis=0)])


def prior(sc: Scenario) -> tuple[np.ndarray, np.ndarray]:
    """``m0 (4,)``, ``P0 (4, 4)`` at the first scan (module docstring)."""
    b = np.radians(45.0)
    u = np.array([np.sin(b), np.cos(b)])  # north-cw bearing 045: the line of sight
    n = np.array([u[1], -u[0]])
    c = np.radians(sc.course_deg)
    m0 = np.r_[sc.range_m * u, sc.speed * np.sin(c), sc.speed * np.cos(c)]
    pos = sc.along_m**2 * np.outer(u, u) + sc.across_m**2 * np.outer(n, n)
    return m0, np.block([[pos, np.zeros((2, 2))], [np.zeros((2, 2)), 4.0 * np.eye(2)]])


def turn(sc: Scenario) -> np.ndarray:
    """``(4, 4)`` the target's manoeuvre: its velocity turned clockwise by ``sc.turn_deg``."""
    c, s = np.cos(np.radians(sc.turn_deg)), np.sin(np.radians(sc.turn_deg))
    t = np.eye(4)
    t[2:, 2:] = [[c, s], [-s, c]]  # (east, north) velocity: the course (north-cw) grows by turn_deg
    return t


def step(sc: Scenario, k: int) -> np.ndarray:
    """``(4, 4)`` the truth's transition from scan k - 1 to scan k: constant velocity, then at
    ``TURN_SCAN`` the turn (the position moves on the old velocity for that minute)."""
    f = cv_model(DT, 0.0)[0]
    return turn(sc) @ f if sc.turn_deg and k == TURN_SCAN else f


def transition(sc: Scenario, k: int) -> np.ndarray:
    """``(4, 4)`` the truth's map from scan 0 to scan k."""
    f = cv_model(DT, 0.0)[0]
    if not sc.turn_deg or k < TURN_SCAN:
        return np.linalg.matrix_power(f, k)
    return np.linalg.matrix_power(f, k - TURN_SCAN) @ turn(sc) @ np.linalg.matrix_power(f, TURN_SCAN)


def draw(sc: Scenario, runs: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Truths ``(R, K, 4)`` drawn from the prior and north-cw bearings ``(R, K)``."""
    m0, p0 = prior(sc)
    chol = np.linalg.cholesky(p0)
    x0, noise = np.empty((runs, 4)), np.empty((runs, SCANS))
    for r, ss in enumerate(np.random.SeedSequence(seed).spawn(runs)):
        g = np.random.default_rng(ss)
        x0[r] = m0 + chol @ g.standard_normal(4)
        noise[r] = g.standard_normal(SCANS)
    truth = np.stack([x0 @ transition(sc, k).T for k in range(SCANS)], axis=1)
    d = truth[..., :2] - ownship()
    return truth, np.arctan2(d[..., 0], d[..., 1]) + np.radians(sc.sigma_deg) * noise


def bound(sc: Scenario, truth: np.ndarray) -> np.ndarray:
    """``(K,)`` the Bayesian CRLB's position RMSE at each scan (module docstring)."""
    _, p0 = prior(sc)
    h = np.zeros((*truth.shape[:2], 4))
    h[..., :2] = bearing_gradients(truth[:, :, None, :2], ownship()[None, :, None])[:, :, 0, 0]
    info = np.einsum("rki,rkj->kij", h, h) / len(truth) / np.radians(sc.sigma_deg) ** 2
    j, out = np.linalg.inv(p0) + info[0], np.empty(SCANS)
    for k in range(SCANS):  # a recursion over scans
        if k:
            fi = np.linalg.inv(step(sc, k))
            j = fi.T @ j @ fi + info[k]
        c = np.linalg.inv(j)
        out[k] = np.sqrt(c[0, 0] + c[1, 1])
    return out


# ------------------------------------------- the methods: (R, 4) final state and covariance, (R, K, 2) positions
def control(sc, bearings, m0, p0):
    f = cv_model(DT, 0.0)[0]
    fk = np.linalg.matrix_power(f, SCANS - 1)
    track = np.stack([np.linalg.matrix_power(f, k) @ m0 for k in range(SCANS)])[None, :, :2]
    return (np.broadcast_to(fk @ m0, (len(bearings), 4)), np.broadcast_to(fk @ p0 @ fk.T, (len(bearings), 4, 4)),
            np.broadcast_to(track, (len(bearings), SCANS, 2)))


def plkf(kind):
    def method(sc, bearings, m0, p0):
        f, q = cv_model(DT, Q_PSD)
        kf = PseudoLinearKF(kind, f, q, np.tile(m0, (len(bearings), 1)), p0)
        east = convert(bearings, "north-cw", "east-ccw")
        obs, track = ownship(), []
        for k in range(SCANS):
            kf.step(east[:, k], obs[k], np.radians(sc.sigma_deg))
            track.append(kf.x[:, :2])
        return kf.x, kf.p, np.stack(track, 1)
    return method


def plmmse(sc, bearings, m0, p0):
    f, q = cv_model(DT, Q_PSD)
    noise = GaussianMixture((1.0,), (np.radians(sc.sigma_deg) ** 2,))
    x, p = np.tile(m0, (len(bearings), 1)), np.tile(p0, (len(bearings), 1, 1))
    east, obs, track = convert(bearings, "north-cw", "east-ccw"), ownship(), []
    for k in range(SCANS):
        if k:
            x, p = plkf_predict(x, p, f, q)
        x, p, _ = PLMMSE_UPDATES["pl-mmse"](x, p, east[:, k], obs[k], noise)
        track.append(x[:, :2])
    return x, p, np.stack(track, 1)


def batch(method_name):
    def method(sc, bearings, m0, p0):
        times = np.arange(SCANS) * DT
        rngs = [np.random.default_rng(r) for r in range(len(bearings))]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # counted below, as lost tracks
            est = BatchTMA(np.radians(sc.sigma_deg), method=method_name, rng=rngs,
                           area=_area(sc)).fit(times, bearings, ownship())
        f = cv_model(DT, 0.0)[0]
        fk = np.linalg.matrix_power(f, SCANS - 1)
        return est.x_ @ fk.T, fk @ est.cov_ @ fk.T, None  # a batch fit of all scans: no estimate per scan
    return method


def _area(sc):
    from uavsim.estimators import SearchArea

    return SearchArea(range_max=3.0 * sc.range_m, speed_max=15.0)


def ckf_update(x, p, bearing, obs, var):
    """One cubature update of ``x (B, 4)``, ``p (B, 4, 4)`` by north-cw bearings ``(B,)`` from
    ``obs (2,)``: 2n points ``x +- sqrt(n) S e_i``, weights 1/2n.  Returns the updated ``x``,
    ``p``, the innovation ``(B,)`` and its variance ``(B,)``."""
    unit = np.sqrt(4.0) * np.concatenate([np.eye(4), -np.eye(4)])  # (8, 4)
    s = np.linalg.cholesky(p)
    pts = x[:, None] + np.einsum("rij,pj->rpi", s, unit)  # (B, 8, 4)
    d = pts[..., :2] - obs
    d0 = x[:, :2] - obs
    centre = np.arctan2(d0[:, 0], d0[:, 1])
    z = centre[:, None] + wrap_angle(np.arctan2(d[..., 0], d[..., 1]) - centre[:, None])
    zh = z.mean(1)
    pzz = ((z - zh[:, None]) ** 2).mean(1) + var
    pxz = ((pts - x[:, None]) * (z - zh[:, None])[..., None]).mean(1)
    gain = pxz / pzz[:, None]
    nu = wrap_angle(bearing - zh)
    x = x + gain * nu[:, None]
    p = p - pzz[:, None, None] * gain[:, :, None] * gain[:, None, :]
    return x, 0.5 * (p + np.swapaxes(p, 1, 2)), nu, pzz


def ckf(sc, bearings, m0, p0):
    """Cubature Kalman filter over runs (Arasaratnam and Haykin 2009; :func:`ckf_update`)."""
    f, q = cv_model(DT, Q_PSD)
    r = len(bearings)
    x, p = np.tile(m0, (r, 1)), np.tile(p0, (r, 1, 1))
    obs, var, track = ownship(), np.radians(sc.sigma_deg) ** 2, []
    for k in range(SCANS):
        if k:
            x, p = plkf_predict(x, p, f, q)
        x, p, _, _ = ckf_update(x, p, bearings[:, k], obs[k], var)
        track.append(x[:, :2])
    return x, p, np.stack(track, 1)


def mixture(w, x, p):
    """The moment-matched Gaussian of a mixture: weights ``w (R, M)`` (rows summing to 1),
    means ``x (R, M, 4)``, covariances ``p (R, M, 4, 4)``; returns ``(R, 4)``, ``(R, 4, 4)``."""
    mean = np.einsum("rm,rmi->ri", w, x)
    dev = x - mean[:, None]
    return mean, np.einsum("rm,rmij->rij", w, p + dev[..., :, None] * dev[..., None, :])


def log_likelihood(nu, var):
    """``(...)`` the log of a Gaussian's density at innovation ``nu`` of variance ``var``, both ``(...)``."""
    return -0.5 * (nu**2 / var + np.log(2.0 * np.pi * var))


def ekf_update(x, p, bearing, obs, var):
    """One extended-Kalman update of ``x (B, 4)``, ``p (B, 4, 4)`` by north-cw bearings ``(B,)``
    from ``obs (2,)``, the bearing linearised at ``x``.  Returns ``x``, ``p``, the innovation
    ``(B,)`` and its variance ``(B,)``."""
    h = np.zeros_like(x)
    h[:, :2] = bearing_gradients(x[:, None, :2], obs[None, None])[:, 0, 0]  # (B, 4): d bearing / d state
    d = x[:, :2] - obs
    nu = wrap_angle(bearing - np.arctan2(d[:, 0], d[:, 1]))
    ph = np.einsum("rij,rj->ri", p, h)
    s = np.einsum("ri,ri->r", h, ph) + var
    gain = ph / s[:, None]
    x = x + gain * nu[:, None]
    p = p - s[:, None, None] * gain[:, :, None] * gain[:, None, :]
    return x, 0.5 * (p + np.swapaxes(p, 1, 2)), nu, s


def range_bank(sc, m0, p0):
    """The RP-EKF's ``BANK`` filters at the first scan: weights ``(M,)``, means ``(M, 4)``,
    covariances ``(M, 4, 4)`` (module docstring)."""
    u = m0[:2] / np.linalg.norm(m0[:2])  # the prior's line of sight
    n = np.array([u[1], -u[0]])
    lo, hi = sc.range_m - 3.0 * sc.along_m, sc.range_m + 3.0 * sc.along_m
    edges = lo * (hi / lo) ** (np.arange(BANK + 1) / BANK)  # geometric cells [edges[i], edges[i + 1]]
    ranges = 0.5 * (edges[1:] + edges[:-1])
    std = (edges[1:] - edges[:-1]) / np.sqrt(12.0)  # the cell's uniform spread: std / range the same for all
    w = np.diff(edges) * np.exp(-0.5 * ((ranges - sc.range_m) / sc.along_m) ** 2)  # the prior's mass in the cell
    x = np.tile(m0, (BANK, 1))
    x[:, :2] = ranges[:, None] * u
    p = np.tile(p0, (BANK, 1, 1))
    p[:, :2, :2] = std[:, None, None] ** 2 * np.outer(u, u) + sc.across_m**2 * np.outer(n, n)
    return w / w.sum(), x, p


def rp_ekf(sc, bearings, m0, p0):
    """Range-parameterised EKF over runs x filters (Peach 1995; module docstring)."""
    f, q = cv_model(DT, Q_PSD)
    r = len(bearings)
    w0, x0, pp0 = range_bank(sc, m0, p0)
    logw = np.tile(np.log(w0), (r, 1))  # (R, M)
    x, p = np.tile(x0, (r, 1)), np.tile(pp0, (r, 1, 1))  # (R M, 4), (R M, 4, 4), run-major
    obs, var, track = ownship(), np.radians(sc.sigma_deg) ** 2, []
    for k in range(SCANS):
        if k:
            x, p = plkf_predict(x, p, f, q)
        x, p, nu, s = ekf_update(x, p, bearings[:, k].repeat(BANK), obs[k], var)
        logw += log_likelihood(nu, s).reshape(r, BANK)
        logw -= logw.max(1, keepdims=True)
        w = np.exp(logw)
        w /= w.sum(1, keepdims=True)
        track.append(np.einsum("rm,rmi->ri", w, x.reshape(r, BANK, 4)[..., :2]))
    return (*mixture(w, x.reshape(r, BANK, 4), p.reshape(r, BANK, 4, 4)), np.stack(track, 1))


def imm(sc, bearings, m0, p0):
    """Interacting multiple model over runs (Blom and Bar-Shalom 1988): a near-constant-velocity
    CKF (``Q_PSD``) and a manoeuvre CKF (``Q_MANOEUVRE``), switching by ``SWITCH`` a scan."""
    f = cv_model(DT, 0.0)[0]
    q = np.stack([cv_model(DT, Q_PSD)[1], cv_model(DT, Q_MANOEUVRE)[1]])  # (M, 4, 4)
    r, m = len(bearings), len(q)
    mu = np.full((r, m), 1.0 / m)  # (R, M) the mode probabilities
    x, p = np.tile(m0, (r, m, 1)), np.tile(p0, (r, m, 1, 1))  # (R, M, 4), (R, M, 4, 4)
    obs, var, track = ownship(), np.radians(sc.sigma_deg) ** 2, []
    for k in range(SCANS):
        if k:
            c = mu @ SWITCH  # (R, M) the predicted mode probabilities
            mix = mu[:, :, None] * SWITCH / c[:, None]  # (R, from, to)
            x, p = zip(*(mixture(mix[:, :, j], x, p) for j in range(m)))
            x, p = plkf_predict(np.stack(x, 1), np.stack(p, 1), f, q)
            mu = c
        xb, pb, nu, s = ckf_update(x.reshape(r * m, 4), p.reshape(r * m, 4, 4), bearings[:, k].repeat(m), obs[k], var)
        x, p = xb.reshape(r, m, 4), pb.reshape(r, m, 4, 4)
        logw = np.log(mu) + log_likelihood(nu, s).reshape(r, m)
        mu = np.exp(logw - logw.max(1, keepdims=True))
        mu /= mu.sum(1, keepdims=True)
        track.append(np.einsum("rm,rmi->ri", mu, x[..., :2]))
    return (*mixture(mu, x, p), np.stack(track, 1))


def weighted_moments(x, w):
    """Mean ``(R, 4)`` and covariance ``(R, 4, 4)`` of particles ``x (R, 4, N)`` with weights
    ``w (R, N)`` (rows summing to 1)."""
    mean = np.matmul(x, w[:, :, None])[..., 0]
    dev = x - mean[:, :, None]
    return mean, np.matmul(dev * w[:, None], np.swapaxes(dev, 1, 2))


def systematic(w, rng):
    """``(R, N)`` indices drawn by systematic resampling from each row of weights ``w (R, N)``:
    the points ``(u + i) / N``, ``u`` uniform a row; particle j gets as many copies as points
    fall between its cumulative weights (the first index whose cumulative weight reaches a point)."""
    r, n = w.shape
    cum = np.cumsum(w, axis=1, dtype=np.float64)
    cum /= cum[:, -1:]
    reached = np.clip(np.floor(n * cum - rng.random((r, 1))) + 1.0, 0, n)  # (R, N) the points <= cum
    copies = np.diff(reached, axis=1, prepend=0.0).astype(np.intp)
    return np.repeat(np.tile(np.arange(n), r), copies.ravel()).reshape(r, n)


def rpf(sc, bearings, m0, p0, seed=0):
    """Regularised particle filter over runs (module docstring).  The particles ``(R, 4, N)``
    are single precision (a metre at 10 km is 1e-4 of the range, float32 keeps 6e-8), and only
    the runs whose sample size fell are resampled."""
    rng = np.random.default_rng(seed)
    r, n, f32 = len(bearings), PARTICLES, np.float32
    chol = np.linalg.cholesky(p0).astype(f32)
    x = np.matmul(chol, rng.standard_normal((r, 4, n), dtype=f32)) + m0.astype(f32)[:, None]
    logw = np.zeros((r, n), f32)
    obs, half_info, track = ownship().astype(f32), f32(0.5 / np.radians(sc.sigma_deg) ** 2), []
    sin_z, cos_z = np.sin(bearings).astype(f32), np.cos(bearings).astype(f32)  # (R, K)
    h_opt = f32((4.0 / (n * 6.0)) ** (1.0 / 8.0))  # the optimal Gaussian kernel width for n = 4 dimensions
    for k in range(SCANS):
        if k:
            x[:, :2] += f32(DT) * x[:, 2:]
        dx, dy = x[:, 0] - obs[k, 0], x[:, 1] - obs[k, 1]  # (R, N)
        s, c = sin_z[:, k, None], cos_z[:, k, None]
        e = np.arctan2(dx * c - dy * s, dx * s + dy * c)  # the particle's bearing minus the measured, in (-pi, pi]
        logw -= half_info * e * e
        logw -= logw.max(1, keepdims=True)
        w = np.exp(logw)
        w /= w.sum(1, keepdims=True)
        track.append(np.matmul(x[:, :2], w[:, :, None])[..., 0])
        low = np.flatnonzero(1.0 / (w * w).sum(1) < n / 2)  # the runs to resample
        if len(low):
            _, cov = weighted_moments(x[low], w[low])
            kernel = h_opt * np.linalg.cholesky(cov.astype(np.float64) + 1e-9 * np.eye(4)).astype(f32)
            drawn = np.take_along_axis(x[low], systematic(w[low], rng)[:, None], axis=2)
            x[low] = drawn + np.matmul(kernel, rng.standard_normal((len(low), 4, n), dtype=f32))
            logw[low] = 0.0
            w[low] = 1.0 / n
    mean, cov = weighted_moments(x, w)
    return mean.astype(np.float64), cov.astype(np.float64), np.stack(track, 1).astype(np.float64)


METHODS = {"no-update control": control, "IV-PLKF": plkf("iv-plkf"), "BC-PLKF": plkf("bc-plkf"),
           "UB-PLKF": plkf("ub-plkf"), "PL-MMSE": plmmse, "batch ML, damped NR": batch("nr"),
           "batch ML, NRPSO + polish": batch("nrpso"), "CKF (baseline)": ckf, "RPF (baseline)": rpf,
           "RP-EKF (baseline)": rp_ekf, "IMM CKF (baseline)": imm}


def study(sc: Scenario, runs: int, seed: int) -> dict:
    truth, bearings = draw(sc, runs, seed)
    m0, p0 = prior(sc)
    b = bound(sc, truth)
    final = truth[:, -1]
    out = {"bound_final_m": float(b[-1]), "bound_m": b.tolist(), "methods": {}}
    for name, method in METHODS.items():
        t0 = time.perf_counter()
        with np.errstate(all="ignore"):
            x, p, track = method(sc, bearings, m0, p0)
        seconds = time.perf_counter() - t0
        err = np.hypot(*(x[:, :2] - final[:, :2]).T)
        kept = np.isfinite(err) & np.isfinite(p).all(axis=(1, 2))
        err = np.where(kept, err, np.inf)
        nees = metrics.nees(x[kept, :2] - final[kept, :2], p[kept][:, :2, :2])
        rng_final = np.hypot(*(final[:, :2] - ownship()[-1]).T)
        out["methods"][name] = {
            "rmse_m": float(np.sqrt(np.mean(err[kept] ** 2))), "ratio": float(np.sqrt(np.mean(err[kept] ** 2)) / b[-1]),
            "lost": float(np.mean(err > LOST * rng_final)), "nonfinite": int((~kept).sum()),
            "median_m": float(np.median(err)), "nees_pos": float(np.mean(nees)),
            "seconds_per_run": seconds / runs,
            "rmse_per_scan_m": None if track is None else  # the runs kept at the last scan
            np.sqrt(np.mean(np.sum((track[kept] - truth[kept, :, :2]) ** 2, axis=-1), axis=0)).tolist()}
    return out


def body(args) -> dict:
    figures = {"runs": args.runs, "seed": args.seed, "scenarios": {}}
    for sc in SCENARIOS:
        s = study(sc, args.runs, args.seed)
        figures["scenarios"][sc.name] = s
        print(f"{sc.name}: {args.runs} runs, sigma {sc.sigma_deg} deg; Bayesian CRLB at the last scan "
              f"{s['bound_final_m']:.0f} m")
        print(f"  {'method':28s}{'RMSE m':>9s}{'/ bound':>9s}{'lost':>7s}{'median m':>10s}{'NEES':>8s}{'ms/run':>8s}")
        for name, m in s["methods"].items():
            print(f"  {name:28s}{m['rmse_m']:9.0f}{m['ratio']:9.2f}{m['lost']:7.1%}{m['median_m']:10.0f}"
                  f"{m['nees_pos']:8.2f}{1e3 * m['seconds_per_run']:8.2f}")
    return figures


if __name__ == "__main__":
    ap = parser(__doc__)
    ap.add_argument("--runs", type=int, default=500)
    ap.add_argument("--seed", type=int, default=1)
    run(body, ap)
