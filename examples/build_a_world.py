"""Build your own world in Python: area, cuboid obstacles, a goal, two targets.

Writes a world and a mission file from Python values (``json.dumps`` writes a TOML
value), shows validation refusing a goal placed inside an obstacle, then validates the
good pair with ``uavsim.config.load_mission``, flies one short trial with
``uavsim.sim.Simulation`` and draws the world top-down with the truth and estimates.

    python examples/build_a_world.py [--full]
"""

import json
import sys
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from uavsim.config import load_mission
from uavsim.mission import MissionError
from uavsim.sim import Simulation

AREA = ([0.0, 0.0, 0.0], [900.0, 700.0, 150.0])  # m: min and max corners
OBSTACLES = {  # name: (min corner, max corner), m
    "warehouse": ([300.0, 250.0, 0.0], [480.0, 400.0, 30.0]),
    "tower": ([600.0, 430.0, 0.0], [640.0, 470.0, 120.0]),  # taller than the UAV flies: it goes round
    "shed": ([150.0, 420.0, 0.0], [230.0, 500.0, 15.0]),
}
GOAL = {"name": "depot", "center_m": [780.0, 120.0], "size_m": [80.0, 80.0]}
TARGETS = {"T1": [100.0, 600.0, 0.0], "T2": [450.0, 640.0, 0.0]}  # start positions (prior means), m
UAV_START = [250.0, 150.0, 40.0]  # m; the UAV flies at 40 m (the default altitude)


def world_toml(goal: dict) -> str:
    lines = ['name = "yard"', "", "[area]", f"min_m = {json.dumps(AREA[0])}", f"max_m = {json.dumps(AREA[1])}"]
    for name, (lo, hi) in OBSTACLES.items():
        lines += ["", "[[obstacles]]", f"name = {json.dumps(name)}", f"min_m = {json.dumps(lo)}",
                  f"max_m = {json.dumps(hi)}"]
    lines += ["", "[[goals]]"] + [f"{k} = {json.dumps(v)}" for k, v in goal.items()]
    return "\n".join(lines) + "\n"


def mission_toml(steps: int, particles: int, horizon: int) -> str:
    lines = ['world = "yard.world.toml"', f"steps = {steps}", "seed = 7",
             "", "[uav]", "random_start = false", f"start_m = {json.dumps(UAV_START)}",
             "", "[guidance]", f"horizon = {horizon}", "", "[filter]", f"particles = {particles}"]
    for name, start in TARGETS.items():  # every other setting takes its default (the paper's)
        lines += ["", "[[targets]]", f"name = {json.dumps(name)}", f"position_m = {json.dumps(start)}",
                  f"goal = {json.dumps(GOAL['name'])}"]
    return "\n".join(lines) + "\n"


def main(out_dir=None, small=True):
    out = Path(out_dir or "out")
    out.mkdir(parents=True, exist_ok=True)
    folder = out / "yard"  # the files stay: `uavsim run out/yard/yard.toml` runs them too
    folder.mkdir(exist_ok=True)
    # small: 15 steps, 1000 particles, a 20-step guidance horizon; --full: the defaults' 50, 5000, 50
    sizes = dict(steps=15, particles=1000, horizon=20) if small else dict(steps=50, particles=5000, horizon=50)
    (folder / "yard.toml").write_text(mission_toml(**sizes))

    (folder / "yard.world.toml").write_text(world_toml({**GOAL, "center_m": [390.0, 320.0]}))  # inside the warehouse
    try:
        load_mission(folder / "yard.toml")
        refused = None
    except MissionError as exc:
        refused = f"{exc.key}: {exc.message}"
        print(f"refused, as it should be: {refused}")

    (folder / "yard.world.toml").write_text(world_toml(GOAL))
    mission = load_mission(folder / "yard.toml")
    sim = Simulation(mission, "optimized")
    steps = [sim.reset(mission.seed)] + [sim.step() for _ in range(mission.steps)]
    truth = np.array([s.truth[:, :2] for s in steps])  # (steps + 1, targets, 2)
    mean = np.array([s.mean[:, :2] for s in steps])
    uav = np.array([s.uav[:2] for s in steps])

    fig = Figure(figsize=(6.4, 5.2), layout="constrained")
    ax = fig.subplots()
    lo, hi = np.array(AREA[0]), np.array(AREA[1])
    ax.add_patch(Rectangle(lo[:2], *(hi - lo)[:2], fill=False, lw=1.5))
    for name, (o_lo, o_hi) in OBSTACLES.items():
        ax.add_patch(Rectangle(o_lo[:2], o_hi[0] - o_lo[0], o_hi[1] - o_lo[1], color="0.6"))
        ax.annotate(f"{name}\n{o_hi[2]:g} m", np.add(o_lo[:2], o_hi[:2]) / 2, ha="center", va="center", fontsize=8)
    c, s = np.array(GOAL["center_m"]), np.array(GOAL["size_m"])
    ax.add_patch(Rectangle(c - s / 2, *s, color="tab:red", alpha=0.4, label=f"goal {GOAL['name']}"))
    for j, target in enumerate(mission.targets):
        (line,) = ax.plot(*truth[:, j].T, lw=2, label=f"{target.name} truth")
        ax.plot(*mean[:, j].T, "--", color=line.get_color(), label=f"{target.name} estimate")
    ax.plot(*uav.T, "k.-", ms=3, lw=0.8, label="UAV")
    ax.plot(*uav[0], "k^")
    ax.set(xlim=(lo[0], hi[0]), ylim=(lo[1], hi[1]), aspect="equal", xlabel="x (m)", ylabel="y (m)",
           title=f"your world: {mission.steps} steps of the optimized UAV")
    ax.legend(fontsize=7, loc="lower left")
    figure = out / f"{Path(__file__).stem}.png"
    fig.savefig(figure, dpi=100)

    error = np.hypot(*(mean[-1] - truth[-1]).T)
    std = np.sqrt(np.trace(steps[-1].cov[:, :2, :2], axis1=1, axis2=2))  # the filter's own position std
    print(f"{len(OBSTACLES)} obstacles, {len(TARGETS)} targets, {mission.steps} steps")
    for j, target in enumerate(mission.targets):
        print(f"{target.name}: position error after the last step {error[j]:.1f} m, the filter's std {std[j]:.1f} m")
    return {"figure": figure, "error": error, "std": std, "refused": refused, "folder": folder}


if __name__ == "__main__":
    print(f"wrote {main(small='--full' not in sys.argv)['figure']}")
