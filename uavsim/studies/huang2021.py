"""``uavsim tma reproduce NAME``: the study of [Huang2021] Sec. 3.

Runs every filter of :mod:`uavsim.estimators.plkf` on the same R runs (batched: one array op per scan for
all runs), then writes ``result.json`` (per filter: RMSE curves, time-averaged RMSE,
seconds per scan; the CRLB / constrained CRLB curves where the paper plots them: for the
truth simulated here, a deterministic path (Q = 0), and, apart, the paper's curve computed
with the filters' Q, which bounds a random truth, not this one: IV-PLKF beats it);
:func:`uavsim.studies.plots.tma_rmse_plot` draws it like the paper's Figs. 3, 5 and 7.
"""

from __future__ import annotations

import time

import numpy as np

from ..bounds.crlb import constrained, crlb, rmse_bounds
from ..estimators.plkf import FILTERS, PseudoLinearKF
from .huang2021_scenarios import Scenario, draw_runs, rmse_curves, scenario, time_averaged


def run_filter(kind: str, sc: Scenario, x0: np.ndarray, bearings: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
    """Estimates ``(R, K, 4)`` of one filter over all runs, wall seconds, degenerate counts (R,)."""
    kf = PseudoLinearKF(kind, sc.f, sc.q, x0, sc.p0, v_min=sc.v_min, v_max=sc.v_max)
    est = np.empty((*bearings.shape, 4))
    t0 = time.perf_counter()
    for k in range(bearings.shape[1]):
        kf.step(bearings[:, k], sc.observer[k], sc.sigma)
        est[:, k] = kf.x
    return est, time.perf_counter() - t0, kf.degenerate


def run_control(sc: Scenario, x0: np.ndarray) -> np.ndarray:
    """The no-update control: the same runs with every bearing update off, i.e. the prior
    ``x0 (R, 4)`` predicted (the filters' own first scan is an update without a
    prediction, so the control holds ``x0`` there).  Estimates ``(R, K, 4)``."""
    est = np.empty((x0.shape[0], len(sc.truth), 4))
    est[:, 0] = x0
    for k in range(1, len(sc.truth)):
        est[:, k] = est[:, k - 1] @ sc.f.T
    return est


def reproduce(name: str, runs: int, seed: int, filters=FILTERS) -> dict:
    """The result dictionary written to ``result.json`` (curves as lists)."""
    sc = scenario(name)
    x0, bearings = draw_runs(sc, runs, seed)
    out = {"scenario": name, "figure": sc.figure, "runs": runs, "seed": seed, "scans": len(sc.truth),
           "sigma_assumed_deg": float(np.degrees(sc.sigma)), "v_min_mps": sc.v_min, "v_max_mps": sc.v_max,
           "filters": {}}
    pos, vel = rmse_curves(run_control(sc, x0), sc.truth)
    out["control"] = {"rmse_pos_m": pos.tolist(), "rmse_vel_mps": vel.tolist(),
                      "time_avg_rmse_pos_m": time_averaged(pos), "time_avg_rmse_vel_mps": time_averaged(vel)}
    for kind in filters:
        est, seconds, degenerate = run_filter(kind, sc, x0, bearings)
        pos, vel = rmse_curves(est, sc.truth)
        finite = np.isfinite(est).all(axis=(1, 2))
        out["filters"][kind] = {
            "rmse_pos_m": pos.tolist(), "rmse_vel_mps": vel.tolist(),
            "time_avg_rmse_pos_m": time_averaged(pos), "time_avg_rmse_vel_mps": time_averaged(vel),
            "seconds_per_scan": seconds / len(sc.truth), "seconds_per_scan_per_run": seconds / len(sc.truth) / runs,
            "degenerate_updates": int(degenerate.sum()), "diverged_runs": int((~finite).sum()),
            # the share of the no-update control's position error the bearings removed
            "bought": 1.0 - time_averaged(pos) / out["control"]["time_avg_rmse_pos_m"],
        }
    if sc.with_crlb:
        bound = crlb(sc.truth, sc.observer, sc.sigma_true, sc.f, np.zeros((4, 4)), sc.p0)  # the truth: no noise
        paper = crlb(sc.truth, sc.observer, sc.sigma_true, sc.f, sc.q, sc.p0)
        for key, b in (("crlb", bound), ("ccrlb", constrained(bound, sc.truth)), ("paper_crlb", paper)):
            pos, vel = rmse_bounds(b)
            out[key] = {"pos_m": pos.tolist(), "vel_mps": vel.tolist(),
                        "time_avg_pos_m": time_averaged(pos), "time_avg_vel_mps": time_averaged(vel)}
    return out


TABLE2 = {"bc-plkf": 1.35, "iv-plkf": 2.12, "ub-plkf": 1.0, "vc-plkf": 1.21}  # [Huang2021] Table 2: runtime / UB


def table(result: dict) -> str:
    """The printed summary: time-averaged RMSEs and runtimes normalised by UB-PLKF."""
    f = result["filters"]
    ub = f.get("ub-plkf", {}).get("seconds_per_scan")
    lines = [f"{result['scenario']} ({result['figure']}): {result['runs']} runs, seed {result['seed']}, "
             f"time-averaged over scans 60..{result['scans']}; the paper prints RMSEs only as figures, its runtimes "
             "in Table 2",
             f"{'filter':10s}{'pos RMSE (m)':>14s}{'vel RMSE (m/s)':>16s}{'runtime / UB':>14s}{'published':>11s}"
             f"{'bought':>9s}"]
    for kind, r in f.items():
        rel = f"{r['seconds_per_scan'] / ub:14.2f}" if ub else f"{'-':>14s}"
        published = f"{TABLE2[kind]:11.2f}" if kind in TABLE2 else f"{'-':>11s}"
        bought = f"{r['bought']:9.1%}" if "bought" in r else ""
        lines.append(f"{kind:10s}{r['time_avg_rmse_pos_m']:14.2f}{r['time_avg_rmse_vel_mps']:16.3f}{rel}{published}"
                     f"{bought}")
    if "control" in result:
        c = result["control"]
        lines.append(f"{'no-update':10s}{c['time_avg_rmse_pos_m']:14.2f}{c['time_avg_rmse_vel_mps']:16.3f}   "
                     "the same runs, every bearing update off (bought: the share of its position RMSE removed)")
    said = {"crlb": "for this truth (deterministic: Q = 0); no unbiased filter goes below it",
            "ccrlb": "the same, on the true speed's sphere (a filter that knows the speed)",
            "paper_crlb": "the paper's curve, with the filters' Q: bounds a random truth, not this one"}
    for key in ("crlb", "ccrlb", "paper_crlb"):
        if key in result:
            lines.append(f"{key.upper():10s}{result[key]['time_avg_pos_m']:14.2f}"
                         f"{result[key]['time_avg_vel_mps']:16.3f}   {said[key]}")
    return "\n".join(lines)
