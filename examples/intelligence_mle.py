"""The constrained MLE with an intelligence region [Oliva2021].

Bearings from a short, nearly straight observer path say little about range; the
intelligence that the target stays inside a disc (a port's basin, say) makes the fit
usable.  Fitted with and without the disc; the constrained fit must respect it.

    python examples/intelligence_mle.py
"""

import numpy as np

from uavsim.estimators import ConstrainedMLE, Disc

rng = np.random.default_rng(3)
times = np.arange(0.0, 300.0, 5.0)  # s
truth = np.column_stack([2000 + 3.0 * times, 3000 - 1.5 * times])  # m, constant velocity
observers = np.column_stack([50 * np.sin(times / 60), 2.0 * times])  # m
d = truth - observers
bearings = np.arctan2(d[:, 1], d[:, 0]) + rng.normal(0, np.radians(1.5), len(times))  # from +x, anticlockwise

basin = Disc(centre=(2450.0, 2775.0), radius=700.0)
for name, inside in (("bearings only", ()), ("inside the basin", (basin,))):
    fit = ConstrainedMLE(np.radians(1.5), inside=inside, order=1, convention="east-ccw").fit(times, bearings,
                                                                                            observers)
    err = np.hypot(*(fit.predict(times) - truth).T)
    print(f"{name:<18} mean position error {err.mean():7.1f} m, converged {fit.converged_}, "
          f"largest violation {fit.violation_:.2e} m")
