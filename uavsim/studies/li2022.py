"""The simulation study of [Li2022] Sec. 5 as data, its metrics and its tables.

Three scenarios (``li2022-line``: Table 5, Figs. 4-7; ``li2022-arc-slow``: Table 7,
Figs. 8-11; ``li2022-arc-fast``: Table 9, Figs. 12-15), N = 200 scans of T = 0.1 s, each
with 12 filter rows: PL-MMSE, PLKF, BC-PLKF, IVKF (:mod:`uavsim.estimators.plmmse`) and each of them
constrained twice (:mod:`uavsim.estimators.constraints`): ``-C(W=I)`` and ``-C(W=P^-1)`` on the line
(Eq. 72-73), ``-L`` and ``-S`` on the arc (Eq. 76-80, then the tangent velocity, Eq. 81-83).

Readings (where the paper is ambiguous, what we chose):

* Observer (Sec. 5.2): five constant-velocity legs of 40 scans through (60, 0), (0, 7.5),
  (60, 15), (0, 22.5), (60, 30), (0, 37.5) m, at (60, 0) at scan 1.  The print ends at
  (0, 77.5), which breaks the 7.5 m zig-zag; we read 37.5.
* Truth: deterministic, an exact line or an exact circle (the constraints hold exactly;
  with process noise on the truth ``G x = g`` would not).
* Bearing noise (Eq. 75): ``e = rho [lambda N(0, R1) + (1 - lambda) N(0, R2)]`` read as
  component variances ``rho^2 R_i`` (rad^2); the printed ``rho^2`` outside the brackets
  would give 370 deg at rho = 7.  The tables' labels are
  ``sigma_theta = rho * {1 deg, 1e-5 deg, 1/sqrt(10) deg}`` (Tables 4, 6, 8); they equal
  ``sqrt(rho^2 R_bar 180 / pi)`` deg, a units slip: "sigma_theta = 7 deg" means rho = 7
  (an actual std of 52.9 deg, 5.30e-4 deg and 16.76 deg).  The filters know the mixture.
* Process noise (Eq. 74): the filters use ``Q = lambda Q1 + (1 - lambda) Q2`` through
  ``D`` (Eq. 12, 14).  The initial estimate ``x^_{1|1}`` is the truth plus GM noise
  with covariance ``P_{1|1}`` (Sec. 5.2); we give that mixture the bearing noise's
  weights and relative spreads ``R_i / R_bar``.
* Arc fast: ``x_1 = [200, 0, 0, 0.2]`` (the print lost a 0).
* The constrained estimate is an output; the filter runs on from ``x^`` (Table 2/3 step 6).

:class:`Reading` holds these choices; its alternatives exist to measure how far each one
moves the tables (``benchmarks/li2022_readings.py``, docs/results/li2022.md).

Metrics (Eq. 64-71) on the output estimate, position (1:2) and velocity (3:4):
``RMSE_k`` and ``BNorm_k = |mean over runs of the error|`` per scan; their time averages
over scans ``L0 = 50 .. N`` (``B = 151``): ``RMSE_avg`` the root of the mean over runs and
scans of the squared error, ``BNorm_avg`` the mean of ``BNorm_k``.  For an unbiased filter
``BNorm`` is the Monte-Carlo floor, about ``0.886 RMSE / sqrt(M0)``: not reproducible.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass

import numpy as np

from ..estimators.constraints import Chain, LinearProjection, NonlinearProjection, TangentVelocity, circle
from ..estimators.plmmse import FILTERS, GaussianMixture, PseudoLinearGM, cv_model

N_SCANS, DT, L0, RHO = 200, 0.1, 50, 7.0
LAMBDA = 0.4
WAYPOINTS = np.array([[60, 0], [0, 7.5], [60, 15], [0, 22.5], [60, 30], [0, 37.5]])  # Sec. 5.2, 37.5 read
SCANS_PER_LEG = 40
LABELS = {"pl-mmse": "PL-MMSE", "plkf": "PLKF", "bc-plkf": "BC-PLKF", "ivkf": "IVKF"}
METRICS = ("rmse_pos", "rmse_vel", "bnorm_pos", "bnorm_vel")

# Tables 5, 7, 9: rows in the paper's order, (RMSEpos, RMSEvel, BNormpos, BNormvel) in the
# table's units (``unit_scale`` below: Table 7 prints x1e-4 m, x1e-5 m/s, x1e-5 m, x1e-6 m/s).
_LINE = {
    "PL-MMSE": (2.294, 0.140, 0.139, 0.011), "PLKF": (27.068, 2.069, 22.202, 1.791),
    "BC-PLKF": (3.714, 0.273, 0.270, 0.010), "IVKF": (3.648, 0.299, 0.219, 0.021),
    "PL-MMSE-C(W=I)": (1.781, 0.103, 0.084, 0.001), "PL-MMSE-C(W=P^-1)": (1.781, 0.103, 0.084, 0.001),
    "PLKF-C(W=I)": (24.350, 1.907, 18.847, 1.557), "PLKF-C(W=P^-1)": (23.027, 1.804, 17.739, 1.458),
    "BC-PLKF-C(W=I)": (2.890, 0.207, 0.234, 0.008), "BC-PLKF-C(W=P^-1)": (2.883, 0.207, 0.267, 0.008),
    "IVKF-C(W=I)": (2.537, 0.198, 0.104, 0.013), "IVKF-C(W=P^-1)": (2.842, 0.204, 0.097, 0.016),
}
_ARC_SLOW = {
    "PL-MMSE": (2.263, 1.726, 3.528, 3.344), "PLKF": (2.346, 1.949, 3.673, 3.541),
    "BC-PLKF": (2.345, 1.949, 3.667, 3.537), "IVKF": (2.345, 1.949, 3.667, 3.537),
    "PL-MMSE-L": (1.579, 1.415, 1.518, 1.590), "PL-MMSE-S": (1.579, 1.408, 1.518, 1.708),
    "PLKF-L": (1.677, 1.650, 1.716, 1.994), "PLKF-S": (1.677, 1.650, 1.716, 1.994),
    "BC-PLKF-L": (1.677, 1.672, 1.716, 1.794), "BC-PLKF-S": (1.677, 1.650, 1.716, 1.993),
    "IVKF-L": (1.677, 1.672, 1.716, 1.794), "IVKF-S": (1.677, 1.650, 1.716, 1.993),
}
_ARC_FAST = {
    "PL-MMSE": (0.224, 0.017, 0.025, 0.004), "PLKF": (0.789, 0.058, 0.499, 0.039),
    "BC-PLKF": (0.321, 0.025, 0.034, 0.005), "IVKF": (0.326, 0.025, 0.028, 0.004),
    "PL-MMSE-L": (0.176, 0.013, 0.011, 0.001), "PL-MMSE-S": (0.176, 0.013, 0.011, 0.001),
    "PLKF-L": (0.310, 0.024, 0.095, 0.008), "PLKF-S": (0.310, 0.024, 0.095, 0.008),
    "BC-PLKF-L": (0.271, 0.021, 0.016, 0.001), "BC-PLKF-S": (0.271, 0.021, 0.016, 0.001),
    "IVKF-L": (0.294, 0.023, 0.017, 0.001), "IVKF-S": (0.294, 0.023, 0.017, 0.001),
}
# Prose values beside the sweeps (Sec. 5.3): (rho, filter label) -> (RMSEpos, RMSEvel) or RMSEpos.
PROSE = {
    "li2022-line": {},
    "li2022-arc-slow": {(10.0, "PL-MMSE"): (2.526e-4, 1.783e-5)},  # Fig. 8, rho not stated: presumably 10
    "li2022-arc-fast": {(3.0, "PL-MMSE"): (0.3346, None), (3.0, "PL-MMSE-S"): (0.2954, None)},  # Fig. 12
}


@dataclass(frozen=True)
class Reading:
    """Where the paper reads more than one way; the defaults are ours (module docstring).

    ``noise="label"``: the bearing std equals the tables' sigma_theta label.
    ``last_waypoint_y=77.5``: the observer's last waypoint as printed.
    ``velocity_angle="origin"``: Eq. (83)'s angle as printed.
    ``feedback=True``: ``x~`` replaces ``x^`` before the next prediction.
    ``baseline_moment="var"``: PLKF, BC-PLKF, IVKF use ``E e^2`` for ``E sin^2 e``.
    ``pl_mmse_r_scale=2``: PL-MMSE's ``R_k`` doubled (a fit to the tables, not a reading)."""

    noise: str = "var"
    last_waypoint_y: float = 37.5
    velocity_angle: str = "centre"
    feedback: bool = False
    baseline_moment: str = "sin2"
    pl_mmse_r_scale: float = 1.0

    def __post_init__(self):
        for key, allowed in (("noise", ("var", "label")), ("velocity_angle", ("centre", "origin")),
                             ("baseline_moment", ("sin2", "var"))):
            if getattr(self, key) not in allowed:
                raise ValueError(f"Reading.{key} must be one of {', '.join(allowed)}, got {getattr(self, key)!r}")
        if not self.pl_mmse_r_scale > 0:
            raise ValueError(f"Reading.pl_mmse_r_scale must be positive, got {self.pl_mmse_r_scale!r}")

    def options(self, kind: str) -> dict:
        """Keyword arguments of ``kind``'s update under this reading."""
        if kind == "pl-mmse":
            return {} if self.pl_mmse_r_scale == 1.0 else {"r_scale": self.pl_mmse_r_scale}
        return {} if self.baseline_moment == "sin2" else {"moment": self.baseline_moment}


@dataclass(frozen=True)
class Li2022Scenario:
    """One study: ``truth (K, 4)``, ``observer (K, 2)``, the bearing-noise mixture at
    ``rho = 1`` (rad), the initial-estimate mixture (covariance ``P_{1|1}``), the model
    ``F``, ``D Q D^T``, the constrained variants (suffix -> ``(x, P) -> (x~, ok)``), the
    published table and its units, and the label ``sigma_theta`` per unit ``rho`` (deg)."""

    name: str
    truth: np.ndarray
    observer: np.ndarray
    bearing: GaussianMixture
    initial: GaussianMixture
    p0: np.ndarray
    f: np.ndarray
    q: np.ndarray
    variants: dict
    table: str
    figures: str
    published: dict
    unit_scale: tuple[float, float, float, float]
    label_deg_per_rho: float


def observer_track(last_waypoint_y: float = 37.5) -> np.ndarray:
    """Sec. 5.2: positions (N, 2) at scans 1..N along the waypoints, 40 scans a leg."""
    wp = WAYPOINTS.astype(float)
    wp[-1, 1] = last_waypoint_y
    k = np.arange(N_SCANS)
    leg, frac = k // SCANS_PER_LEG, (k % SCANS_PER_LEG / SCANS_PER_LEG)[:, None]
    return wp[leg] + frac * (wp[leg + 1] - wp[leg])


def line_truth(speed: float = 12.0, theta: float = np.pi / 4) -> np.ndarray:
    """Sec. 5.3, scenario 1: from the origin at ``speed`` along ``theta`` (N, 4)."""
    v = speed * np.array([np.cos(theta), np.sin(theta)])
    t = DT * np.arange(N_SCANS)[:, None]
    return np.hstack([t * v, np.tile(v, (N_SCANS, 1))])


def arc_truth(speed: float, centre=(100.0, 0.0), radius: float = 100.0) -> np.ndarray:
    """Sec. 5.3, scenario 2: anticlockwise on the circle from ``centre + (R, 0)`` (N, 4)."""
    ang = speed / radius * DT * np.arange(N_SCANS)
    c, s = np.cos(ang), np.sin(ang)
    return np.stack([centre[0] + radius * c, centre[1] + radius * s, -speed * s, speed * c], -1)


def _mixtures(r1: float, r2: float, q1: float, q2: float, p0: np.ndarray):
    w = (LAMBDA, 1 - LAMBDA)
    bearing = GaussianMixture(w, [r1, r2])
    r_bar = bearing.cov[0, 0]
    process = GaussianMixture(w, [np.diag([0, 0, q1, q1]), np.diag([0, 0, q2, q2])])
    return bearing, GaussianMixture(w, [p0 * r1 / r_bar, p0 * r2 / r_bar]), process


def scenario(name: str, reading: Reading = Reading()) -> Li2022Scenario:
    """``li2022-line``, ``li2022-arc-slow`` or ``li2022-arc-fast`` (module docstring)."""
    if name == "li2022-line":
        theta = np.pi / 4
        g_mat = np.array([[1, -np.tan(theta), 0, 0], [0, 0, 1, -np.tan(theta)]])  # Eq. (72)-(73)
        variants = {"-C(W=I)": LinearProjection(g_mat, np.zeros(2), "I"),
                    "-C(W=P^-1)": LinearProjection(g_mat, np.zeros(2), "P")}
        p0, truth = np.diag([1.0, 1, 0.01, 0.01]), line_truth(12.0, theta)
        noise = (0.015, 0.019, 0.15, 0.23)
        meta = dict(table="Table 5", figures="Figs. 4-7", published=_LINE, unit_scale=(1, 1, 1, 1),
                    label_deg_per_rho=1.0)
    elif name in ("li2022-arc-slow", "li2022-arc-fast"):
        centre, radius = (100.0, 0.0), 100.0
        con, vel = circle(centre, radius), TangentVelocity(centre, reading.velocity_angle)
        variants = {"-L": Chain((NonlinearProjection(con, "linear"), vel)),
                    "-S": Chain((NonlinearProjection(con, "second-order"), vel))}
        if name == "li2022-arc-slow":
            p0, truth = np.diag([1e-8, 1e-8, 1e-10, 1e-10]), arc_truth(1e-4, centre, radius)
            noise = (1.5e-12, 1.909e-12, 1e-9, 2e-9)
            meta = dict(table="Table 7", figures="Figs. 8-11", published=_ARC_SLOW,
                        unit_scale=(1e-4, 1e-5, 1e-5, 1e-6), label_deg_per_rho=1e-5)
        else:
            p0, truth = np.diag([1e-3, 1e-3, 1e-4, 1e-4]), arc_truth(0.2, centre, radius)
            noise = (1.5e-3, 1.909e-3, 0.01, 0.02)
            meta = dict(table="Table 9", figures="Figs. 12-15", published=_ARC_FAST, unit_scale=(1, 1, 1, 1),
                        label_deg_per_rho=1 / np.sqrt(10))
    else:
        raise ValueError(f"unknown scenario {name!r}; choose from {', '.join(SCENARIOS)}")
    bearing, initial, process = _mixtures(*noise, p0)
    if reading.noise == "label":
        bearing = bearing.scaled(np.radians(meta["label_deg_per_rho"]) / np.sqrt(bearing.cov[0, 0]))
    f, q = cv_model(DT, process)
    return Li2022Scenario(name, truth, observer_track(reading.last_waypoint_y), bearing, initial, p0, f, q,
                          variants, **meta)


SCENARIOS = ("li2022-line", "li2022-arc-slow", "li2022-arc-fast")


def draw_runs(sc: Li2022Scenario, runs: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Per run r (seeded by ``SeedSequence(seed).spawn(runs)[r]``): the initial estimate
    ``x^_{1|1} (R, 4)`` and the bearing noise at ``rho = 1`` ``(R, N)`` (rad); the noise at
    ``rho`` is ``rho`` times it (common random numbers across a sweep and across filters)."""
    x0, noise = np.empty((runs, 4)), np.empty((runs, N_SCANS))
    for r, ss in enumerate(np.random.SeedSequence(seed).spawn(runs)):
        rng = np.random.default_rng(ss)
        x0[r] = sc.truth[0] + sc.initial.sample(rng, 1)[0]
        noise[r] = sc.bearing.sample(rng, N_SCANS)[:, 0]
    return x0, noise


def true_bearings(sc: Li2022Scenario) -> np.ndarray:
    """Eq. (3): ``atan2(ty - sy, tx - sx)`` (N,)."""
    rel = sc.truth[:, :2] - sc.observer
    return np.arctan2(rel[:, 1], rel[:, 0])


def run_filter(kind: str, sc: Li2022Scenario, x0: np.ndarray, bearings: np.ndarray, rho: float,
               constraint=None, feedback: bool = False, options: dict | None = None):
    """One filter over all runs from ``x^_{1|1}`` through scans 2..N (the wrapper
    :class:`uavsim.estimators.plmmse.PseudoLinearGM`).  Returns the output estimates ``(R, N, 4)`` (the
    constrained ones when there is a ``constraint``), the filter's own estimates and
    covariances ``(R, N, 4)``, ``(R, N, 4, 4)``, degenerate counts (R,) and wall seconds."""
    kf = PseudoLinearGM(kind, sc.f, sc.q, sc.bearing.scaled(rho), x0, sc.p0, constraint, feedback, options or {})
    est, x, p = np.empty((*bearings.shape, 4)), np.empty((*bearings.shape, 4)), np.empty((*bearings.shape, 4, 4))
    est[:, 0], x[:, 0], p[:, 0] = kf.estimate, kf.x, kf.p
    t0 = time.perf_counter()
    for k in range(1, bearings.shape[1]):
        kf.step(bearings[:, k], sc.observer[k])
        est[:, k], x[:, k], p[:, k] = kf.estimate, kf.x, kf.p
    return est, x, p, kf.degenerate, time.perf_counter() - t0


def run_rows(sc: Li2022Scenario, x0: np.ndarray, noise: np.ndarray, rho: float, reading: Reading = Reading()) -> dict:
    """All 12 rows at noise scale ``rho``: label -> (estimates (R, N, 4), degenerate
    count, wall seconds).  Without feedback the constrained rows project each scan's
    unconstrained estimate afterwards (the same numbers as running the wrapper with the
    constraint; one filter run serves three rows); with feedback each row runs on its own."""
    bearings = true_bearings(sc) + rho * noise
    base, rows = {}, {}
    for kind in FILTERS:
        base[kind] = run_filter(kind, sc, x0, bearings, rho, options=reading.options(kind))
        est, _, _, degenerate, seconds = base[kind]
        rows[LABELS[kind]] = (est, int(degenerate.sum()), seconds)
    for suffix, constrain in sc.variants.items():
        for kind in FILTERS:
            if reading.feedback:
                est, _, _, degenerate, seconds = run_filter(kind, sc, x0, bearings, rho, constrain, True,
                                                            reading.options(kind))
                rows[LABELS[kind] + suffix] = (est, int(degenerate.sum()), seconds)
                continue
            _, x, p, degenerate, seconds = base[kind]
            t0 = time.perf_counter()
            xc, ok = constrain(x.reshape(-1, 4), p.reshape(-1, 4, 4))
            rows[LABELS[kind] + suffix] = (xc.reshape(x.shape), int(degenerate.sum() + (~ok).sum()),
                                           seconds + time.perf_counter() - t0)
    return {label: rows[label] for label in sc.published}  # the paper's row order


def control_rows(sc: Li2022Scenario, x0: np.ndarray) -> dict:
    """The no-update control of every row: the same runs with every bearing update off.
    The filters then only predict from ``x^_{1|1}`` (the same for every filter), and a
    constrained row projects that prediction with its constraint.  label -> estimates
    ``(R, N, 4)``."""
    x, p = np.empty((*x0.shape[:1], N_SCANS, 4)), np.empty((x0.shape[0], N_SCANS, 4, 4))
    x[:, 0], p[:, 0] = x0, sc.p0
    for k in range(1, N_SCANS):
        x[:, k] = x[:, k - 1] @ sc.f.T
        p[:, k] = sc.f @ p[:, k - 1] @ sc.f.T + sc.q
    rows = {LABELS[kind]: x for kind in FILTERS}
    for suffix, constrain in sc.variants.items():
        xc = constrain(x.reshape(-1, 4), p.reshape(-1, 4, 4))[0].reshape(x.shape)
        rows.update({LABELS[kind] + suffix: xc for kind in FILTERS})
    return {label: rows[label] for label in sc.published}


def metrics(est: np.ndarray, truth: np.ndarray, first: int = L0) -> dict:
    """Eq. (64)-(71) from estimates ``(R, N, 4)``: per-scan curves ``(N,)`` and their
    time averages over scans ``first..N`` (1-based)."""
    err = est - truth
    out = {}
    for part, sl in (("pos", slice(0, 2)), ("vel", slice(2, 4))):
        sq = np.sum(err[..., sl] ** 2, axis=-1)  # (R, N)
        rmse = np.sqrt(sq.mean(axis=0))  # Eq. (64), (66)
        bnorm = np.linalg.norm(err[..., sl].mean(axis=0), axis=-1)  # Eq. (65), (67)
        out[f"rmse_{part}"] = rmse
        out[f"bnorm_{part}"] = bnorm
        out[f"rmse_{part}_avg"] = float(np.sqrt(sq[:, first - 1:].mean()))  # Eq. (68), (70)
        out[f"bnorm_{part}_avg"] = float(bnorm[first - 1:].mean())  # Eq. (69), (71)
    return out


def _row_result(sc: Li2022Scenario, label: str, est: np.ndarray, degenerate: int, seconds: float, runs: int) -> dict:
    m = metrics(est, sc.truth)
    finite = np.isfinite(est).all(axis=(1, 2))
    row = {f"{k}_avg": m[f"{k}_avg"] for k in METRICS}
    row.update(degenerate=degenerate, diverged_runs=int((~finite).sum()),
               seconds_per_scan_per_run=seconds / N_SCANS / runs)
    return row, m


def reproduce(name: str, runs: int, seed: int, rhos=None, reading: Reading = Reading()) -> dict:
    """The result dictionary written to ``result.json``: at ``rho = 7`` the 12 rows' time
    averages beside the published table with ratios, and per-scan curves (Figs. 5, 9, 13);
    with ``rhos`` also the time averages per ``rho`` (Figs. 4, 8, 12 and their L/S, C
    companions)."""
    sc = scenario(name, reading)
    x0, noise = draw_runs(sc, runs, seed)
    out = {"scenario": name, "table": sc.table, "figures": sc.figures, "runs": runs, "seed": seed,
           "reading": asdict(reading),
           "scans": N_SCANS, "first_averaged_scan": L0, "rho": RHO,
           "sigma_theta_label_deg": RHO * sc.label_deg_per_rho,
           "bearing_std_deg": float(np.degrees(RHO * np.sqrt(sc.bearing.cov[0, 0]))),
           "unit_scale": list(sc.unit_scale), "rows": {}}
    controls = control_rows(sc, x0)
    for label, (est, degenerate, seconds) in run_rows(sc, x0, noise, RHO, reading).items():
        row, m = _row_result(sc, label, est, degenerate, seconds, runs)
        control = metrics(controls[label], sc.truth)
        row["control"] = {f"{k}_avg": control[f"{k}_avg"] for k in METRICS}
        # the share of the no-update control's position error the bearings removed
        row["bought"] = 1.0 - row["rmse_pos_avg"] / control["rmse_pos_avg"]
        pub = [v * s for v, s in zip(sc.published[label], sc.unit_scale)]
        row["published"] = dict(zip(METRICS, pub))
        row["ratio"] = {k: row[f"{k}_avg"] / p for k, p in zip(METRICS, pub)}
        row["curves"] = {k: m[k].tolist() for k in METRICS}
        out["rows"][label] = row
    if rhos:
        out["sweep"] = []
        for rho in rhos:
            rows = {label: _row_result(sc, label, *r, runs)[0]
                    for label, r in run_rows(sc, x0, noise, rho, reading).items()}
            out["sweep"].append({"rho": float(rho), "sigma_theta_label_deg": float(rho * sc.label_deg_per_rho),
                                 "rows": rows})
    return out


def table(result: dict) -> str:
    """The printed table: each row's four time averages, published / ours / ratio, in the
    paper's units."""
    scale = result["unit_scale"]
    units = ["m", "m/s", "m", "m/s"]
    units = [u if s == 1 else f"{s:g} {u}" for u, s in zip(units, scale)]
    head = "".join(f"{m + ' (' + u + ')':>27s}" for m, u in zip(METRICS, units))
    lines = [f"{result['scenario']} ({result['table']}): {result['runs']} runs, seed {result['seed']}, "
             f"rho = {result['rho']:g} (label sigma_theta = {result['sigma_theta_label_deg']:.3g} deg, "
             f"actual std {result['bearing_std_deg']:.3g} deg), time-averaged over scans "
             f"{result['first_averaged_scan']}..{result['scans']}",
             f"{'filter':18s}{head}{'no-update RMSEpos':>19s}{'bought':>8s}",
             f"{'':18s}" + f"{'paper':>9s}{'ours':>9s}{'ratio':>9s}" * 4]
    for label, r in result["rows"].items():
        cells = "".join(f"{r['published'][m] / s:9.3f}{r[m + '_avg'] / s:9.3f}{r['ratio'][m]:9.2f}"
                        for m, s in zip(METRICS, scale))
        control = f"{r['control']['rmse_pos_avg'] / scale[0]:19.3f}{r['bought']:8.1%}" if "control" in r else ""
        lines.append(f"{label:18s}{cells}{control}")
    lines.append("no-update: the same runs with every bearing update off (the prior predicted, constrained as the "
                 "row is); bought: the share of its position RMSE the bearings removed")
    return "\n".join(lines)


def sweep_table(result: dict) -> str:
    """Time-averaged position and velocity RMSE per ``rho`` (paper's units), with the
    prose values the paper quotes for the sweep (Sec. 5.3) where there are any."""
    scale, sweep = result["unit_scale"], result["sweep"]
    prose = PROSE[result["scenario"]]
    lines = [f"{result['scenario']} sweep ({result['figures']}): RMSEpos_avg ({scale[0]:g} m) / "
             f"RMSEvel_avg ({scale[1]:g} m/s) against rho (label sigma_theta = rho x "
             f"{sweep[0]['sigma_theta_label_deg'] / sweep[0]['rho']:.3g} deg)",
             f"{'filter':18s}" + "".join(f"{'rho=' + format(s['rho'], 'g'):>14s}" for s in sweep)]
    for label in sweep[0]["rows"]:
        cells = "".join(f"{r['rmse_pos_avg'] / scale[0]:7.3f}/{r['rmse_vel_avg'] / scale[1]:6.3f}"
                        for r in (s["rows"][label] for s in sweep))
        lines.append(f"{label:18s}{cells}")
    for (rho, label), (pos, vel) in prose.items():
        ours = next((s["rows"][label] for s in sweep if s["rho"] == rho), None)
        if ours is not None:
            vel_txt = "" if vel is None else f", RMSEvel {vel:g} / {ours['rmse_vel_avg']:.4g} m/s"
            lines.append(f"paper's prose at rho = {rho:g}: {label} RMSEpos {pos:g} / ours {ours['rmse_pos_avg']:.4g} m"
                         + vel_txt)
    return "\n".join(lines)
