"""Your own bearings into PL-MMSE, with a road constraint.

A vehicle drives east along a straight road (y = 1200 m); a sensor flies a weaving path
south of it and measures bearings from north, clockwise, in degrees, with heavy-tailed
noise (90% 0.5 deg, 10% 4 deg) and some scans missed (NaN).  PL-MMSE [Li2022] filters
them; the road (y = 1200, vy = 0) is imposed on its estimate by projection [Li2022,
Eq. (31)].  Replace the arrays below with your data.  PL-MMSE skips an update whose gain
would leave the covariance indefinite (heavy-tailed noise, a wide prior); a
DegenerateUpdateWarning says how many it skipped.

    python examples/own_bearings_plmmse.py
"""

import numpy as np

from uavsim.estimators import PLMMSE, GaussianMixture
from uavsim.estimators.constraints import LinearProjection

rng = np.random.default_rng(1)
times = np.arange(0.0, 120.0, 2.0)  # s
truth = np.column_stack([-800 + 12.0 * times, np.full(len(times), 1200.0)])  # m
observers = np.column_stack([300 * np.sin(times / 15), -400 + 5.0 * times])  # m
d = truth - observers
noise_deg = np.where(rng.random(len(times)) < 0.9, 0.5, 4.0) * rng.standard_normal(len(times))
bearings_deg = np.degrees(np.arctan2(d[:, 0], d[:, 1])) + noise_deg  # from north, clockwise
bearings_deg[rng.random(len(times)) < 0.1] = np.nan  # missed scans

noise = GaussianMixture([0.9, 0.1], np.radians([0.5, 4.0]) ** 2)  # a mixture is always in radians
road = LinearProjection(g_mat=np.array([[0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]]), g=np.array([1200.0, 0.0]))
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

for name, track in (("no bearings (prior only)", blind), ("PL-MMSE", tracks), ("PL-MMSE on the road", estimates)):
    err = np.hypot(*(track[:, :2] - truth).T)
    print(f"{name:<26} position error: mean {err.mean():7.1f} m, last {err[-1]:7.1f} m")
print(f"{free.missed} scans missed")
