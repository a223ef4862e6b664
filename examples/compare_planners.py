"""Compare planners: the optimized UAV, a circling UAV and three fixed sensors.

Runs the same trials of the paper mission [Papaioannou2023, Sec. VI-B] under each
planner (a trial's truth, prior and sensor noise do not depend on the planner: common
random numbers), with the no-information baseline for scale, and plots the position
RMSE per step of each (``uavsim compare`` does the same from the command line).

    python examples/compare_planners.py [--full]
"""

import sys
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from uavsim.campaign import run_campaign
from uavsim.config import load_mission

MISSION = Path(__file__).resolve().parents[1] / "missions" / "paper.toml"
PLANNERS = {"optimized": "UAV, Eq. (13)", "circle": "UAV circling", "fixed-sensors": "3 fixed sensors, no clutter",
            "baseline": "no information"}


def main(out_dir=None, small=True):
    # small: 2 trials of 10 steps, 500 particles, a 20-step guidance horizon (the paper: 100 x 50, 5000, 50)
    size = ({"trials": 2, "steps": 10, "filter.particles": 500, "guidance.horizon": 20} if small
            else {"trials": 20})
    mission = load_mission(MISSION, size)
    summaries = {name: run_campaign(mission, name) for name in PLANNERS}

    t = np.arange(1, mission.steps + 1) * mission.dynamics.dt
    fig = Figure(figsize=(6.4, 3.6), layout="constrained")
    ax = fig.subplots()
    for name, label in PLANNERS.items():
        s = summaries[name]
        ax.plot(t, s["rmse"], "k--" if name == "baseline" else "o-", ms=3,
                label=f"{label} ({s['time_avg_rmse']:.1f} m)")
    ax.set(xlabel="time (s)", ylabel="position RMSE (m), mean over targets", ylim=(0, None),
           title=f"{MISSION.stem}: {mission.trials} trials of {mission.steps} steps")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    out = Path(out_dir or "out")
    out.mkdir(parents=True, exist_ok=True)
    figure = out / f"{Path(__file__).stem}.png"
    fig.savefig(figure, dpi=100)

    print(f"{'planner':<15}{'time-avg RMSE':>14}{'last step':>11}")
    for name in PLANNERS:
        s = summaries[name]
        print(f"{name:<15}{s['time_avg_rmse']:>12.1f} m{s['rmse'][-1]:>9.1f} m")
    return {"figure": figure, "rmse": {name: s["time_avg_rmse"] for name, s in summaries.items()}}


if __name__ == "__main__":
    print(f"wrote {main(small='--full' not in sys.argv)['figure']}")
