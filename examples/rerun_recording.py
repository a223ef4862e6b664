"""Record a trial for the rerun viewer.

Runs one short trial of the paper mission with ``uavsim.recording.Recorder`` as its
``on_step`` callback (``uavsim run --record FILE.rrd`` does the same) into a ``.rrd`` file
in a temporary folder: world, truth, estimates, particles, plans, bearings, error plots.
The figure is the real viewer rendered headless (``uavsim.recording.screenshot``; it
needs Vulkan), or else a matplotlib top-down view of the same trial.

    python examples/rerun_recording.py [--full]
"""

import sys
import tempfile
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Polygon, Rectangle

from uavsim.campaign import run_trial, trial_seeds
from uavsim.config import load_mission
from uavsim.recording import Recorder, screenshot, vulkan_available

MISSION = Path(__file__).resolve().parents[1] / "missions" / "paper.toml"


def top_down(infos, mission, path: Path) -> None:
    """The matplotlib stand-in for the viewer: world, truth (solid), estimates (dashed), UAV."""
    w = mission.world
    fig = Figure(figsize=(5.6, 5.6), layout="constrained")
    ax = fig.subplots()
    for v, k in zip(w.footprints.vertices, w.footprints.sides):
        ax.add_patch(Polygon(v[:k], color="0.6"))
    for g in w.goals:
        ax.add_patch(Rectangle(g.lo, *(g.hi - g.lo), color="tab:red", alpha=0.4))
    truth = np.array([i.truth[:, :2] for i in infos])
    mean = np.array([i.mean[:, :2] for i in infos])
    for j, target in enumerate(mission.targets):
        (line,) = ax.plot(*truth[:, j].T, lw=2, label=target.name)
        ax.plot(*mean[:, j].T, "--", color=line.get_color())
    ax.plot(*np.array([i.uav[:2] for i in infos]).T, "k.-", ms=3, lw=0.8, label="UAV")
    ax.set(xlim=(w.area_lo[0], w.area_hi[0]), ylim=(w.area_lo[1], w.area_hi[1]), aspect="equal",
           xlabel="x (m)", ylabel="y (m)", title=f"trial 0, {mission.steps} steps (dashed: estimates)")
    ax.legend(fontsize=8)
    fig.savefig(path, dpi=100)


def main(out_dir=None, small=True, rrd_dir=None, viewer=None):
    """``rrd_dir``: where the recording goes (default: a new temporary folder);
    ``viewer``: render the figure with the rerun viewer (default: when Vulkan is there)."""
    # small: 10 steps, 500 particles (100 drawn), a 20-step guidance horizon (the paper: 50, 5000, 50)
    size = {"steps": 10, "filter.particles": 500, "guidance.horizon": 20} if small else {}
    mission = load_mission(MISSION, size)
    rrd = Path(rrd_dir or tempfile.mkdtemp(prefix="uavsim-rrd-")) / "trial0.rrd"
    recorder = Recorder(rrd, mission, "optimized", trial=0, particles=100 if small else 200)
    infos = []

    def on_step(info):
        recorder(info)
        infos.append(info)

    try:
        result = run_trial(mission, "optimized", 0, trial_seeds(mission.seed, 1)[0], on_step=on_step)
    finally:
        recorder.close()

    out = Path(out_dir or "out")
    out.mkdir(parents=True, exist_ok=True)
    figure = out / f"{Path(__file__).stem}.png"
    drawn_by = "matplotlib"
    if vulkan_available() if viewer is None else viewer:
        try:
            screenshot(rrd, figure, max_size=1280)
            drawn_by = "rerun viewer"
        except Exception as exc:  # no display server, no GPU driver: draw it without the viewer
            print(f"the viewer could not render ({type(exc).__name__}: {exc}); drawing with matplotlib")
    if drawn_by == "matplotlib":
        top_down(infos, mission, figure)

    rms = np.sqrt(result.err2.mean())
    print(f"recorded {mission.steps} steps of {len(mission.targets)} targets: {rrd.stat().st_size / 1e3:.0f} kB")
    print(f"RMS position error over the trial {rms:.1f} m; figure drawn by the {drawn_by}")
    print(f"open it with:  rerun {rrd}")
    return {"figure": figure, "rrd": rrd, "drawn_by": drawn_by, "rms": rms}


if __name__ == "__main__":
    print(f"wrote {main(small='--full' not in sys.argv)['figure']}")
