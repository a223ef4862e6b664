"""A recorded uavsim trial into the batch estimator (NRPSO [Oh2021]).

Runs one trial of the paper mission (the UAV flying Eq. 13's moves), takes target T4's
own bearings from the UAV's scans (``uavsim.sim.target_bearings``: the simulator's
``north-cw`` convention, NaN where the scan missed it, false alarms left out) and fits a
constant-velocity track to the first 20 s, while the target still drives straight.

    python examples/recorded_trial_nrpso.py [--full]
"""

import sys
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from uavsim.campaign import run_trial, trial_seeds
from uavsim.config import load_mission
from uavsim.estimators import BatchTMA
from uavsim.sim import target_bearings

MISSION = Path(__file__).resolve().parents[1] / "missions" / "paper.toml"


def main(out_dir=None, small=True):
    # small: 500 particles in the simulator's filter (the paper: 5000); 20 steps either way
    mission = load_mission(MISSION, {"steps": 20, "filter.particles": 500 if small else 5000,
                                     "sensor.clutter_rate": 0.0})
    infos = []
    run_trial(mission, "optimized", 0, trial_seeds(mission.seed, 1)[0], on_step=infos.append)
    times, bearings, observers, truth = target_bearings(infos, target=3, dt=mission.dynamics.dt)
    seen = ~np.isnan(bearings)
    fit = BatchTMA(mission.sensor.sigma, method="nrpso", rng=np.random.default_rng(0), convention="north-cw")
    fit.fit(times[seen], bearings[seen], observers[seen])
    track = fit.predict(times)[:, :2]
    err = np.hypot(*(track - truth).T)
    crlb = np.sqrt(fit.cov_[0, 0] + fit.cov_[1, 1])

    fig = Figure(figsize=(6.4, 3.6), layout="constrained")
    ax = fig.subplots()
    for k in np.flatnonzero(seen)[::4]:  # every fourth bearing, as a ray 1.3 times the true range long
        reach = 1.3 * np.hypot(*(truth[k] - observers[k]))
        ray = observers[k] + reach * np.array([np.sin(bearings[k]), np.cos(bearings[k])])  # north, clockwise
        ax.plot(*np.column_stack([observers[k], ray]), color="tab:green", lw=0.6, alpha=0.6)
    ax.plot(*observers.T, "k.-", ms=3, lw=0.8, label="UAV (observer)")
    ax.plot(*truth.T, lw=2, color="tab:blue", label="T4 truth")
    ax.plot(*track.T, "--", lw=2, color="tab:orange", label=f"NRPSO fit (mean error {err.mean():.0f} m)")
    ax.plot([], [], color="tab:green", lw=0.6, label="bearings (every fourth)")
    ax.set(aspect="equal", xlabel="x (m)", ylabel="y (m)",
           title=f"target T4: {seen.sum()} of {len(times)} scans, {times[-1]:g} s")
    ax.legend(fontsize=8)
    out = Path(out_dir or "out")
    out.mkdir(parents=True, exist_ok=True)
    figure = out / f"{Path(__file__).stem}.png"
    fig.savefig(figure, dpi=100)

    print(f"{seen.sum()} of {len(times)} scans saw the target; converged: {fit.converged_}")
    print(f"position error: first {err[0]:.1f} m, mean {err.mean():.1f} m, last {err[-1]:.1f} m")
    print(f"CRLB position std at the first scan: {crlb:.1f} m")
    return {"figure": figure, "error": err, "crlb": crlb, "converged": fit.converged_}


if __name__ == "__main__":
    print(f"wrote {main(small='--full' not in sys.argv)['figure']}")
