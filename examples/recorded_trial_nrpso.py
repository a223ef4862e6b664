"""A recorded uavsim trial into the batch estimator (NRPSO [Oh2021]).

Runs one trial of the paper mission (the UAV flying Eq. 13's moves), takes target T4's
own bearings from the UAV's scans (``uavsim.sim.target_bearings``: the simulator's
``north-cw`` convention, NaN where the scan missed it, false alarms left out) and fits a
constant-velocity track to the first 20 s, while the target still drives straight.

    python examples/recorded_trial_nrpso.py
"""

from pathlib import Path

import numpy as np

from uavsim.campaign import run_trial, trial_seeds
from uavsim.config import load_mission
from uavsim.estimators import BatchTMA
from uavsim.sim import target_bearings

mission = load_mission(Path(__file__).resolve().parents[1] / "missions" / "paper.toml",
                       {"steps": 20, "filter.particles": 500, "sensor.clutter_rate": 0.0})
infos = []
run_trial(mission, "optimized", 0, trial_seeds(mission.seed, 1)[0], on_step=infos.append)
times, bearings, observers, truth = target_bearings(infos, target=3, dt=mission.dynamics.dt)
seen = ~np.isnan(bearings)
fit = BatchTMA(mission.sensor.sigma, method="nrpso", rng=np.random.default_rng(0), convention="north-cw")
fit.fit(times[seen], bearings[seen], observers[seen])
track = fit.predict(times)[:, :2]
err = np.hypot(*(track - truth).T)
print(f"{seen.sum()} of {len(times)} scans saw the target; converged: {fit.converged_}")
print(f"position error: first {err[0]:.1f} m, mean {err.mean():.1f} m, last {err[-1]:.1f} m")
print(f"CRLB position std at the first scan: {np.sqrt(fit.cov_[0, 0] + fit.cov_[1, 1]):.1f} m")
