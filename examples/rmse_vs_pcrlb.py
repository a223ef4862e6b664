"""The posterior Cramer-Rao bound beside the RMSE.

Every campaign summary carries ``pcrlb_pos``, the bound on the position RMSE of any
estimator along the paths the trials flew [Tichavsky1998], with missed detections and
clutter through the information reduction factor ``pcrlb_q2``.  Plots the particle
filter's RMSE per step on the paper mission against it: how far the filter is from the
floor.

    python examples/rmse_vs_pcrlb.py [--full]
"""

import sys
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from uavsim.campaign import run_campaign
from uavsim.config import load_mission

MISSION = Path(__file__).resolve().parents[1] / "missions" / "paper.toml"


def main(out_dir=None, small=True):
    # small: 3 trials of 10 steps, 500 particles, a 20-step guidance horizon (the paper: 100 x 50, 5000, 50)
    size = ({"trials": 3, "steps": 10, "filter.particles": 500, "guidance.horizon": 20} if small
            else {"trials": 20})
    mission = load_mission(MISSION, size)
    s = run_campaign(mission, "optimized")
    rmse, bound = np.array(s["rmse"]), np.array(s["pcrlb_pos"])

    t = np.arange(1, mission.steps + 1) * mission.dynamics.dt
    fig = Figure(figsize=(6.4, 3.6), layout="constrained")
    ax = fig.subplots()
    ax.plot(t, rmse, "o-", ms=3, label=f"particle filter RMSE ({s['time_avg_rmse']:.1f} m)")
    ax.plot(t, bound, "k:", lw=2, label=f"PCRLB ({s['time_avg_pcrlb']:.1f} m)")
    ax.fill_between(t, 0, bound, color="0.85", label="out of reach of any estimator (in expectation)")
    ax.set(xlabel="time (s)", ylabel="position error (m), mean over targets", ylim=(0, None),
           title=f"{MISSION.stem}: {mission.trials} trials, clutter rate {mission.sensor.clutter_rate:g}, "
                 f"q2 = {s['pcrlb_q2']:.3f}")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    out = Path(out_dir or "out")
    out.mkdir(parents=True, exist_ok=True)
    figure = out / f"{Path(__file__).stem}.png"
    fig.savefig(figure, dpi=100)

    print(f"information reduction factor q2 = {s['pcrlb_q2']:.3f} (1 would be no misses and no clutter)")
    print(f"time-averaged: RMSE {s['time_avg_rmse']:.1f} m, PCRLB {s['time_avg_pcrlb']:.1f} m "
          f"(ratio {s['time_avg_rmse'] / s['time_avg_pcrlb']:.2f})")
    print(f"last step: RMSE {rmse[-1]:.1f} m, PCRLB {bound[-1]:.1f} m")
    return {"figure": figure, "rmse": rmse, "pcrlb": bound, "q2": s["pcrlb_q2"]}


if __name__ == "__main__":
    print(f"wrote {main(small='--full' not in sys.argv)['figure']}")
