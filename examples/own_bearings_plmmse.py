"""Your own bearings into PL-MMSE, with a road constraint.

A vehicle drives east along a road (y = 1200 m); a sensor weaving south of it measures
bearings from north, clockwise, in degrees, with heavy-tailed noise (90% 0.5 deg, 10%
4 deg) and missed scans (NaN).  PL-MMSE [Li2022] filters them, without and with the road
imposed by projection [Li2022, Eq. (31)].  Replace the arrays with your data; a
DegenerateUpdateWarning counts the updates PL-MMSE skipped (an indefinite covariance).

    python examples/own_bearings_plmmse.py
"""

import sys
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from uavsim.estimators import PLMMSE, GaussianMixture
from uavsim.estimators.constraints import LinearProjection


def main(out_dir=None, small=True):
    """``small`` changes nothing: this runs in well under a second."""
    rng = np.random.default_rng(1)
    times = np.arange(0.0, 120.0, 2.0)  # s
    truth = np.column_stack([-800 + 12.0 * times, np.full(len(times), 1200.0)])  # m
    observers = np.column_stack([300 * np.sin(times / 15), -400 + 5.0 * times])  # m
    d = truth - observers
    noise_deg = np.where(rng.random(len(times)) < 0.9, 0.5, 4.0) * rng.standard_normal(len(times))
    bearings_deg = np.degrees(np.arctan2(d[:, 0], d[:, 1])) + noise_deg  # from north, clockwise
    bearings_deg[rng.random(len(times)) < 0.1] = np.nan  # missed scans

    noise = GaussianMixture([0.9, 0.1], np.radians([0.5, 4.0]) ** 2)  # a mixture is always in radians
    road = LinearProjection(g_mat=np.array([[0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]]),
                            g=np.array([1200.0, 0.0]))
    prior = dict(x0=[-500.0, 1000.0, 5.0, 0.0], P0=np.diag([400.0**2, 300.0**2, 15.0**2, 15.0**2]), q=0.05)

    free = PLMMSE(noise, **prior, units="deg")
    tracks, covs = free.filter(times, bearings_deg, observers)
    on_road = PLMMSE(noise, **prior, units="deg", constraint=road)
    estimates = []
    for k, t in enumerate(times):
        if k:
            on_road.predict(t - times[k - 1])
        on_road.update(None if np.isnan(bearings_deg[k]) else bearings_deg[k], observers[k])
        estimates.append(on_road.estimate)
    estimates = np.array(estimates)
    blind = PLMMSE(noise, **prior).filter(times, np.full(len(times), np.nan), observers)[0]  # no bearings at all

    runs = {"no bearings (prior only)": blind, "PL-MMSE": tracks, "PL-MMSE on the road": estimates}
    errors = {name: np.hypot(*(track[:, :2] - truth).T) for name, track in runs.items()}
    fig = Figure(figsize=(9.6, 3.6), layout="constrained")
    left, right = fig.subplots(1, 2)
    left.plot(*observers.T, "k.-", ms=2, lw=0.6, label="sensor")
    left.plot(*truth.T, lw=4, color="0.75", label="truth, on the road")
    for name, track in runs.items():
        style = "--" if name.startswith("no") else "-"
        left.plot(*track[:, :2].T, style, lw=1.2)
        right.plot(times, errors[name], style, lw=1.2, label=name)
    left.set(xlabel="x (m)", ylabel="y (m)", title="tracks")
    left.legend(fontsize=8)
    right.set(xlabel="time (s)", ylabel="position error (m)", yscale="log", title="errors")
    right.grid(alpha=0.3)
    right.legend(fontsize=8)
    out = Path(out_dir or "out")
    out.mkdir(parents=True, exist_ok=True)
    figure = out / f"{Path(__file__).stem}.png"
    fig.savefig(figure, dpi=100)

    for name, err in errors.items():
        print(f"{name:<26} position error: mean {err.mean():7.1f} m, last {err[-1]:7.1f} m")
    print(f"{free.missed} scans missed")
    return {"figure": figure, "mean_error": {name: float(err.mean()) for name, err in errors.items()}}


if __name__ == "__main__":
    print(f"wrote {main(small='--full' not in sys.argv)['figure']}")
