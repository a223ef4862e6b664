"""The standard bearings-only benchmark: every library method and the field's strong baselines.

    python benchmarks/bo_standard.py [--runs 500] [--seed 1] [--json docs/data/bo-standard.json]

Two scenarios of the kind bearings-only papers compare on (our choice of numbers, written
here; the field's classic is an ownship that turns once so the range becomes observable):

* ``5km``: the target about 5 km away at bearing 045 deg, 3 m/s on course 135 deg; the
  ownship at 5 m/s heads west for 16 scans, then north for 16 (it manoeuvres once, and
  never closes on the target: a pass within a few hundred metres would make the bound's
  expected information that of the rare close runs); one bearing a minute, sigma 1.5 deg,
  32 scans.
* ``10km``: the same geometry at 10 km, the target 5 m/s, sigma 2 deg.

The truth of run r is drawn from the prior every method is given (``SeedSequence(seed)
.spawn(runs)[r]``), ``N(m0, P0)``: the nominal state, 1 km (10 km: 2 km) along the first line
of sight, 300 m (600 m) across it, 2 m/s in each velocity; it then moves at constant
velocity, no process noise.  The bound is the Bayesian CRLB of that truth:
``J_k = F^-T J_{k-1} F^-1 + E[H_k^T H_k] / sigma^2``, ``J_0 = P0^-1``, the expectation
over the runs' own truths; no process noise (the truth has none).

Methods, each over all runs at once: the no-update control (the prior predicted), the
library's IV-, BC- and UB-PLKF ([Huang2021]; a small process noise, q = 1e-5 m^2/s^3),
PL-MMSE ([Li2022], Gaussian noise), batch ML by damped Newton and by polished NRPSO
([Oh2021]; the final scan's state from the fitted track; it uses no prior); and two
baselines written here: a cubature Kalman filter (CKF, Arasaratnam and Haykin 2009) and a
regularised particle filter (RPF, Musso et al. 2001; 4000 particles, resampled below half
the sample size, Gaussian kernel on the weighted covariance).  Reported per method: the
final scan's position RMSE, its ratio to the bound's, the share of lost tracks (a final
error above a quarter of the target's true range), the mean NEES of the final position (dof 2) where the method
has a covariance, and the seconds per run.  Not here yet: a manoeuvring target (and the
IMM it calls for), a range-parameterised EKF.
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


@dataclass(frozen=True)
class Scenario:
    name: str
    range_m: float
    speed: float
    course_deg: float
    sigma_deg: float
    along_m: float  # prior std along the first line of sight
    across_m: float  # ... and across it


SCENARIOS = (Scenario("5km", 5000.0, 3.0, 135.0, 1.5, 1000.0, 300.0),
             Scenario("10km", 10000.0, 5.0, 135.0, 2.0, 2000.0, 600.0))


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


def draw(sc: Scenario, runs: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Truths ``(R, K, 4)`` drawn from the prior and north-cw bearings ``(R, K)``."""
    m0, p0 = prior(sc)
    f = cv_model(DT, 0.0)[0]
    chol = np.linalg.cholesky(p0)
    x0, noise = np.empty((runs, 4)), np.empty((runs, SCANS))
    for r, ss in enumerate(np.random.SeedSequence(seed).spawn(runs)):
        g = np.random.default_rng(ss)
        x0[r] = m0 + chol @ g.standard_normal(4)
        noise[r] = g.standard_normal(SCANS)
    truth = np.stack([x0 @ np.linalg.matrix_power(f, k).T for k in range(SCANS)], axis=1)
    d = truth[..., :2] - ownship()
    return truth, np.arctan2(d[..., 0], d[..., 1]) + np.radians(sc.sigma_deg) * noise


def bound(sc: Scenario, truth: np.ndarray) -> np.ndarray:
    """``(K,)`` the Bayesian CRLB's position RMSE at each scan (module docstring)."""
    _, p0 = prior(sc)
    f = cv_model(DT, 0.0)[0]
    fi = np.linalg.inv(f)
    h = np.zeros((*truth.shape[:2], 4))
    h[..., :2] = bearing_gradients(truth[:, :, None, :2], ownship()[None, :, None])[:, :, 0, 0]
    info = np.einsum("rki,rkj->kij", h, h) / len(truth) / np.radians(sc.sigma_deg) ** 2
    j, out = np.linalg.inv(p0) + info[0], np.empty(SCANS)
    for k in range(SCANS):  # a recursion over scans
        if k:
            j = fi.T @ j @ fi + info[k]
        c = np.linalg.inv(j)
        out[k] = np.sqrt(c[0, 0] + c[1, 1])
    return out


# ---------------------------------------------------------------- the methods: (R, 4) final state and covariance
def control(sc, bearings, m0, p0):
    f = cv_model(DT, 0.0)[0]
    fk = np.linalg.matrix_power(f, SCANS - 1)
    return np.broadcast_to(fk @ m0, (len(bearings), 4)), np.broadcast_to(fk @ p0 @ fk.T, (len(bearings), 4, 4))


def plkf(kind):
    def method(sc, bearings, m0, p0):
        f, q = cv_model(DT, Q_PSD)
        kf = PseudoLinearKF(kind, f, q, np.tile(m0, (len(bearings), 1)), p0)
        east = convert(bearings, "north-cw", "east-ccw")
        obs = ownship()
        for k in range(SCANS):
            kf.step(east[:, k], obs[k], np.radians(sc.sigma_deg))
        return kf.x, kf.p
    return method


def plmmse(sc, bearings, m0, p0):
    f, q = cv_model(DT, Q_PSD)
    noise = GaussianMixture((1.0,), (np.radians(sc.sigma_deg) ** 2,))
    x, p = np.tile(m0, (len(bearings), 1)), np.tile(p0, (len(bearings), 1, 1))
    east, obs = convert(bearings, "north-cw", "east-ccw"), ownship()
    for k in range(SCANS):
        if k:
            x, p = plkf_predict(x, p, f, q)
        x, p, _ = PLMMSE_UPDATES["pl-mmse"](x, p, east[:, k], obs[k], noise)
    return x, p


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
        return est.x_ @ fk.T, fk @ est.cov_ @ fk.T
    return method


def _area(sc):
    from uavsim.estimators import SearchArea

    return SearchArea(range_max=3.0 * sc.range_m, speed_max=15.0)


def ckf(sc, bearings, m0, p0):
    """Cubature Kalman filter over runs: 2n points ``x +- sqrt(n) S e_i``, weights 1/2n."""
    f, q = cv_model(DT, Q_PSD)
    r = len(bearings)
    x, p = np.tile(m0, (r, 1)), np.tile(p0, (r, 1, 1))
    obs, var = ownship(), np.radians(sc.sigma_deg) ** 2
    unit = np.sqrt(4.0) * np.concatenate([np.eye(4), -np.eye(4)])  # (8, 4)
    for k in range(SCANS):
        if k:
            x, p = plkf_predict(x, p, f, q)
        s = np.linalg.cholesky(p)
        pts = x[:, None] + np.einsum("rij,pj->rpi", s, unit)  # (R, 8, 4)
        d = pts[..., :2] - obs[k]
        d0 = x[:, :2] - obs[k]
        centre = np.arctan2(d0[:, 0], d0[:, 1])
        z = centre[:, None] + wrap_angle(np.arctan2(d[..., 0], d[..., 1]) - centre[:, None])
        zh = z.mean(1)
        pzz = ((z - zh[:, None]) ** 2).mean(1) + var
        pxz = ((pts - x[:, None]) * (z - zh[:, None])[..., None]).mean(1)
        gain = pxz / pzz[:, None]
        x = x + gain * wrap_angle(bearings[:, k] - zh)[:, None]
        p = p - pzz[:, None, None] * gain[:, :, None] * gain[:, None, :]
        p = 0.5 * (p + np.swapaxes(p, 1, 2))
    return x, p


def rpf(sc, bearings, m0, p0, seed=0):
    """Regularised particle filter over runs (module docstring)."""
    rng = np.random.default_rng(seed)
    f = cv_model(DT, 0.0)[0]
    r, n = len(bearings), PARTICLES
    x = m0 + rng.standard_normal((r, n, 4)) @ np.linalg.cholesky(p0).T
    logw = np.zeros((r, n))
    obs, sig = ownship(), np.radians(sc.sigma_deg)
    h_opt = (4.0 / (n * 6.0)) ** (1.0 / 8.0)  # the optimal Gaussian kernel width for n = 4 dimensions
    rows = np.arange(r)[:, None]
    for k in range(SCANS):
        if k:
            x = x @ f.T
        d = x[..., :2] - obs[k]
        logw += -0.5 * (wrap_angle(bearings[:, k, None] - np.arctan2(d[..., 0], d[..., 1])) / sig) ** 2
        logw -= logw.max(1, keepdims=True)
        w = np.exp(logw)
        w /= w.sum(1, keepdims=True)
        ess = 1.0 / (w**2).sum(1)
        low = ess < n / 2
        if low.any():
            mean = np.einsum("rn,rni->ri", w, x)
            dev = x - mean[:, None]
            cov = np.einsum("rn,rni,rnj->rij", w, dev, dev) + 1e-9 * np.eye(4)
            cum = np.cumsum(w, axis=1)
            cum[:, -1] = 1.0
            u = (rng.random((r, 1)) + np.arange(n)) / n
            idx = np.minimum((cum + np.arange(r)[:, None]).ravel().searchsorted((u + np.arange(r)[:, None]).ravel())
                             - np.arange(r).repeat(n) * n, n - 1).reshape(r, n)
            jitter = h_opt * np.einsum("rij,rnj->rni", np.linalg.cholesky(cov), rng.standard_normal((r, n, 4)))
            x = np.where(low[:, None, None], x[rows, idx] + jitter, x)
            logw = np.where(low[:, None], 0.0, logw)
            w = np.where(low[:, None], 1.0 / n, w)
    mean = np.einsum("rn,rni->ri", w, x)
    dev = x - mean[:, None]
    return mean, np.einsum("rn,rni,rnj->rij", w, dev, dev)


METHODS = {"no-update control": control, "IV-PLKF": plkf("iv-plkf"), "BC-PLKF": plkf("bc-plkf"),
           "UB-PLKF": plkf("ub-plkf"), "PL-MMSE": plmmse, "batch ML, damped NR": batch("nr"),
           "batch ML, NRPSO + polish": batch("nrpso"), "CKF (baseline)": ckf, "RPF (baseline)": rpf}


def study(sc: Scenario, runs: int, seed: int) -> dict:
    truth, bearings = draw(sc, runs, seed)
    m0, p0 = prior(sc)
    b = bound(sc, truth)
    final = truth[:, -1]
    out = {"bound_final_m": float(b[-1]), "bound_m": b.tolist(), "methods": {}}
    for name, method in METHODS.items():
        t0 = time.perf_counter()
        with np.errstate(all="ignore"):
            x, p = method(sc, bearings, m0, p0)
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
            "seconds_per_run": seconds / runs}
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
