"""Run a mission and plot its RMSE against the no-information baseline.

Loads the paper mission [Papaioannou2023, Sec. VI-A] with a few overrides (the same
route as the command line's flags), runs a small Monte-Carlo campaign of the UAV flying
Eq. (13)'s moves, then the same trials with no sensor at all, and plots the position
RMSE per step of both: what the bearings bought.

    python examples/run_mission.py [--full]
"""

import sys
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from uavsim.campaign import run_campaign, with_baseline
from uavsim.config import load_mission

MISSION = Path(__file__).resolve().parents[1] / "missions" / "paper.toml"


def main(out_dir=None, small=True):
    # small: 2 trials of 10 steps, 500 particles, a 20-step guidance horizon (the paper: 100 x 50, 5000, 50)
    size = ({"trials": 2, "steps": 10, "filter.particles": 500, "guidance.horizon": 20} if small
            else {"trials": 20})
    mission = load_mission(MISSION, size)
    uav = run_campaign(mission, "optimized")
    summary = with_baseline(uav, run_campaign(mission, "baseline"))  # the same trials, no sensor
    base = summary["baseline"]

    t = np.arange(1, mission.steps + 1) * mission.dynamics.dt
    fig = Figure(figsize=(6.4, 3.6), layout="constrained")
    ax = fig.subplots()
    ax.plot(t, summary["rmse"], "o-", ms=3, label=f"UAV, Eq. (13) ({summary['time_avg_rmse']:.1f} m)")
    ax.plot(t, base["rmse"], "k--", label=f"no information ({base['time_avg_rmse']:.1f} m)")
    ax.set(xlabel="time (s)", ylabel="position RMSE (m), mean over targets",
           title=f"{MISSION.stem}: {mission.trials} trials, {len(mission.targets)} targets")
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend()
    out = Path(out_dir or "out")
    out.mkdir(parents=True, exist_ok=True)
    figure = out / f"{Path(__file__).stem}.png"
    fig.savefig(figure, dpi=100)

    print(f"{mission.trials} trials x {mission.steps} steps, {len(mission.targets)} targets")
    print(f"time-averaged position RMSE: UAV {summary['time_avg_rmse']:.1f} m, "
          f"no information {base['time_avg_rmse']:.1f} m (ratio {base['ratio']:.2f})")
    print(f"last step: UAV {summary['rmse'][-1]:.1f} m, no information {base['rmse'][-1]:.1f} m")
    return {"figure": figure, "rmse": summary["time_avg_rmse"], "baseline": base["time_avg_rmse"],
            "ratio": base["ratio"]}


if __name__ == "__main__":
    print(f"wrote {main(small='--full' not in sys.argv)['figure']}")
