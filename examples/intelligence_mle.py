"""The constrained MLE with an intelligence region [Oliva2021].

Bearings from a short, nearly straight observer path say little about range; the
intelligence that the target stays inside a disc (a port's basin, say) makes the fit
usable.  Fitted with and without the disc; the constrained fit must respect it.

    python examples/intelligence_mle.py
"""

import sys
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Circle

from uavsim.estimators import ConstrainedMLE, Disc


def main(out_dir=None, small=True):
    """``small`` changes nothing: this runs in well under a second."""
    rng = np.random.default_rng(3)
    times = np.arange(0.0, 300.0, 5.0)  # s
    truth = np.column_stack([2000 + 3.0 * times, 3000 - 1.5 * times])  # m, constant velocity
    observers = np.column_stack([50 * np.sin(times / 60), 2.0 * times])  # m
    d = truth - observers
    bearings = np.arctan2(d[:, 1], d[:, 0]) + rng.normal(0, np.radians(1.5), len(times))  # from +x, anticlockwise

    basin = Disc(centre=(2450.0, 2775.0), radius=700.0)
    fits, errors = {}, {}
    for name, inside in (("bearings only", ()), ("inside the basin", (basin,))):
        fit = ConstrainedMLE(np.radians(1.5), inside=inside, order=1, convention="east-ccw")
        fits[name] = fit.fit(times, bearings, observers)
        errors[name] = np.hypot(*(fit.predict(times)[:, :2] - truth).T)
        print(f"{name:<18} mean position error {errors[name].mean():7.1f} m, converged {fit.converged_}, "
              f"largest violation {fit.violation_:.2e} m")

    fig = Figure(figsize=(5.6, 4.4), layout="constrained")
    ax = fig.subplots()
    ax.add_patch(Circle(basin.centre, basin.radius, color="tab:blue", alpha=0.12, label="intelligence: the basin"))
    ax.plot(*observers.T, "k.-", ms=2, lw=0.6, label="observer")
    ax.plot(*truth.T, lw=4, color="0.7", label="truth")
    for name, fit in fits.items():
        ax.plot(*fit.predict(times)[:, :2].T, "--" if name == "bearings only" else "-",
                label=f"{name} ({errors[name].mean():.0f} m)")
    ax.set(aspect="equal", xlabel="x (m)", ylabel="y (m)", title="constrained MLE, order 1 (constant velocity)")
    ax.legend(fontsize=8, loc="upper left")
    out = Path(out_dir or "out")
    out.mkdir(parents=True, exist_ok=True)
    figure = out / f"{Path(__file__).stem}.png"
    fig.savefig(figure, dpi=100)
    return {"figure": figure, "mean_error": {name: float(e.mean()) for name, e in errors.items()},
            "violation": {name: float(fit.violation_) for name, fit in fits.items()}}


if __name__ == "__main__":
    print(f"wrote {main(small='--full' not in sys.argv)['figure']}")
