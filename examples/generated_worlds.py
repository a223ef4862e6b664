"""Generated worlds: open ground and cities from a seed.

``uavsim.world.generate.generate`` draws a world and a mission from one numpy Generator (the
same seed gives the same bytes; ``uavsim world generate`` from the command line): open
worlds with gates, shielded goals and masts, or towns of streets and buildings.  Each pair is
written as TOML, validated by ``load_mission`` and drawn top-down.

    python examples/generated_worlds.py [--full]
"""

import sys
from pathlib import Path

import numpy as np
from matplotlib import colormaps
from matplotlib.colors import Normalize
from matplotlib.figure import Figure
from matplotlib.patches import Polygon, Rectangle

from uavsim.config import load_mission
from uavsim.world.generate import generate, mission_toml, world_toml


def draw(ax, mission, heights: Normalize) -> None:
    """Obstacles shaded by height (darker: taller), goals red, targets' starts (dots) joined to their goals,
    the UAV's operating region (orange) and start (triangle)."""
    w, cmap = mission.world, colormaps["Greys"]
    ax.add_patch(Rectangle(w.area_lo[:2], *(w.area_hi - w.area_lo)[:2], fill=False))
    feet = w.footprints
    for v, k, hi in zip(feet.vertices, feet.sides, w.obstacle_hi):
        ax.add_patch(Polygon(v[:k], color=cmap(0.25 + 0.75 * heights(hi[2])), lw=0))
    for g in w.goals:
        ax.add_patch(Rectangle(g.lo, *(g.hi - g.lo), color="tab:red", alpha=0.5, lw=0))
    for t, goal in zip(mission.targets, mission.goals):
        ax.plot([t.mean0[0], goal[0]], [t.mean0[1], goal[1]], ":", color="tab:blue", lw=0.8)
        ax.plot(*t.mean0[:2], "o", color="tab:blue", ms=4)
    if mission.uav.region is not None:
        ax.add_patch(Polygon(mission.uav.region.vertices, fill=False, ec="tab:orange", lw=1.2))
    ax.plot(*mission.uav.start[:2], "k^", ms=6)
    ax.set(xlim=(w.area_lo[0], w.area_hi[0]), ylim=(w.area_lo[1], w.area_hi[1]), aspect="equal")
    ax.tick_params(labelsize=7)


def main(out_dir=None, small=True):
    # small: 4 worlds (cities of 40 buildings); --full: 6 (cities of up to 120)
    draws = [("open", 1, 6), ("open", 2, 12), ("city", 3, 40), ("city", 4, 60)]
    if not small:
        draws += [("open", 5, 15), ("city", 6, 120)]
    out = Path(out_dir or "out")
    folder = out / "generated"  # the files stay: `uavsim run out/generated/city-s3.toml` runs one
    folder.mkdir(parents=True, exist_ok=True)
    missions = []
    print(f"{'kind':<6}{'seed':>5}{'area (m)':>14}{'obstacles':>11}{'targets':>9}  free path to the goal (m)")
    for kind, seed, obstacles in draws:
        g = generate(np.random.default_rng(seed), obstacles=obstacles, targets=3, kind=kind)
        stem = f"{kind}-s{seed}"
        (folder / f"{stem}.world.toml").write_text(world_toml(g))
        (folder / f"{stem}.toml").write_text(mission_toml(g, f"{stem}.world.toml"))
        mission = load_mission(folder / f"{stem}.toml")  # validates the pair
        missions.append((stem, mission))
        size = "x".join(f"{v:.0f}" for v in (g.area_hi - g.area_lo)[:2])
        print(f"{kind:<6}{seed:>5}{size:>14}{len(g.obstacle_names):>11}{len(g.target_goals):>9}  "
              f"{', '.join(f'{r:.0f}' for r in g.route_lengths)}")

    heights = Normalize(0, max(m.world.obstacle_hi[:, 2].max() for _, m in missions))
    cols = 2 if small else 3
    fig = Figure(figsize=(4.2 * cols, 7.2), layout="constrained")
    for ax, (stem, mission) in zip(fig.subplots(2, cols).ravel(), missions):
        draw(ax, mission, heights)
        ax.set_title(f"{stem}: {mission.world.n_obstacles} obstacles", fontsize=9)
    fig.suptitle("obstacles darker the taller; goals red; targets blue, joined to their goals; UAV start and "
                 "operating region", fontsize=8)
    figure = out / f"{Path(__file__).stem}.png"
    fig.savefig(figure, dpi=100)
    return {"figure": figure, "missions": missions, "folder": folder}


if __name__ == "__main__":
    print(f"wrote {main(small='--full' not in sys.argv)['figure']}")
