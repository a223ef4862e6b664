"""Random worlds and missions: guidance and the closed loop on geometry they have never seen.

``generate(rng, obstacles=K, targets=N)`` draws a world + mission pair; ``world_toml``
and ``mission_toml`` write them as TOML that ``uavsim validate`` accepts.  Everything
random comes from the one ``numpy.random.Generator`` passed in, and every number is
rounded before it is used, so a seed gives byte-identical files.

What a world holds (each a deliberate test of guidance, sensing or validation):

* an area that is not the paper's 1 km square (600-1600 m by 500-1400 m, never square),
  sometimes offset from the origin;
* 0-15 cuboids: a **gate** (two walls with a narrow corridor between them, 2.5-5
  margins wide, so 0.5-3 margins remain after both walls are inflated), a **shield**
  (one to three walls round a goal, the goal open on one side; a target starts behind
  it), tall thin **masts**, boxes of varied footprint and height, and now and then a box
  off the ground (ignored by ground guidance, an obstacle for the UAV);
* 1-3 goal regions kept clear of the inflated obstacles; 1-8 targets starting outside
  the inflated obstacles by one more margin, also after their first step
  ``p1 = p0 + v0 dt`` (which no control can change), some with a starting velocity;
* every goal reachable: the free-space shortest path from each start to its goal's
  centroid (:func:`uavsim.world.routes.shortest_route` among the inflated footprints) is at
  most ``REACH_FRACTION = 0.6`` of the horizon's straight reach ``T dt v_max`` (480 m
  with the paper's T = 50, dt = 1 s, 16 m/s): the target needs about 5 steps to reach
  full speed and flies an inscribed speed polygon, so 0.6 leaves room to turn;
* a UAV altitude below the tallest obstacle in most worlds (the UAV must fly round it
  too), an operating region (box or convex polygon) in about 40% of them, and fixed
  sensors inside the area and outside obstacles, near the paper's (0.15, 0.2),
  (0.8, 0.2), (0.5, 0.9) of the area.

The dynamics, sensor, UAV grid, guidance and filter settings are the declared defaults
(:mod:`uavsim.declare`: the paper mission's, [Papaioannou2023] Sec. VI-A), written into
the mission by :func:`uavsim.writer.mission_text`.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..declare import specs
from ..uav import FixedSensorsConfig, ManoeuvreConfig, PlannerConfig
from ..writer import mission_text, value_text
from . import city, town
from .draw import Generated, Settings, draw_fixed_sensors, draw_target, draw_uav, ground_boxes
from .model import Region2D
from .routes import GoalField
from .space import free_space

MAX_OBSTACLES, MAX_TARGETS = 15, 8


# --------------------------------------------------------------------------- the open kind
class _Layout:
    """The obstacles placed so far and the rules a new one must meet."""

    def __init__(self, area_lo, area_hi, goals_lo, goals_hi, keep_clear: float):
        self.area_lo, self.area_hi = area_lo, area_hi
        self.clear_lo, self.clear_hi = goals_lo - keep_clear, goals_hi + keep_clear
        self.lo: list[np.ndarray] = []
        self.hi: list[np.ndarray] = []
        self.names: list[str] = []

    def fits(self, lo: np.ndarray, hi: np.ndarray, spacing: float = 1.0) -> bool:
        """Inside the area, clear of the goals, not overlapping another obstacle."""
        if np.any(lo < self.area_lo) or np.any(hi > self.area_hi):
            return False
        if np.any(np.all((lo[:2] < self.clear_hi) & (hi[:2] > self.clear_lo), axis=1)):
            return False
        if self.lo:
            o_lo, o_hi = np.array(self.lo)[:, :2] - spacing, np.array(self.hi)[:, :2] + spacing
            if np.any(np.all((lo[:2] < o_hi) & (hi[:2] > o_lo), axis=1)):
                return False
        return True

    def add(self, boxes: list[tuple[np.ndarray, np.ndarray]], kind: str) -> bool:
        """Add the boxes of one feature if all fit (a feature's own boxes may touch)."""
        if not all(self.fits(lo, hi) for lo, hi in boxes):
            return False
        for lo, hi in boxes:
            self.names.append(f"{kind}{len(self.lo) + 1}"), self.lo.append(lo), self.hi.append(hi)
        return True


def _box(centre_xy, size_xy, z0: float, z1: float) -> tuple[np.ndarray, np.ndarray]:
    """A cuboid from its (x, y) centre and size, corners rounded to whole metres."""
    c, s = np.asarray(centre_xy, dtype=float), np.asarray(size_xy, dtype=float)
    lo, hi = np.round(c - s / 2), np.round(c + s / 2)
    hi = np.maximum(hi, lo + 1.0)
    return np.array([lo[0], lo[1], z0]), np.array([hi[0], hi[1], z1])


AXES = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])  # +x, +y, -x, -y


def _gate(rng, goal_c, goal_s, margin) -> list[tuple[np.ndarray, np.ndarray]]:
    """Two walls across the approach to a goal with a corridor between them."""
    u = AXES[rng.integers(4)]
    w = np.array([u[1], u[0]])  # along the wall
    dist = np.abs(u) @ goal_s / 2 + margin + rng.uniform(60, 200)
    depth, gap = rng.uniform(15, 80), np.round(rng.uniform(2.5, 5.0) * margin)
    mid = goal_c + dist * u + w * rng.uniform(-40, 40)
    height = float(np.round(rng.uniform(15, 120)))
    out = []
    for side in (-1, 1):
        length = rng.uniform(60, 250)
        c = mid + side * w * (gap / 2 + length / 2)
        out.append(_box(c, np.abs(u) * depth + np.abs(w) * length, 0.0, height))
    return out


def _shield(rng, goal_c, goal_s, margin, walls: int) -> tuple[list, np.ndarray]:
    """One to three walls round a goal (open on the side away from the first wall);
    returns the walls and the direction (from the goal) behind the first one."""
    u = AXES[rng.integers(4)]
    w = np.array([u[1], u[0]])
    half_u, half_w = np.abs(u) @ goal_s / 2, np.abs(w) @ goal_s / 2
    gap, thick = margin + rng.uniform(25, 60), rng.uniform(10, 40)
    span = 2 * (half_w + gap + thick) + rng.uniform(0, 60)
    height = float(np.round(rng.uniform(20, 150)))
    out = [_box(goal_c + (half_u + gap + thick / 2) * u, np.abs(u) * thick + np.abs(w) * span, 0.0, height)]
    side_len = 2 * (half_u + gap) + rng.uniform(0, 40)
    for side in (-1, 1)[: walls - 1]:
        c = goal_c + side * (half_w + gap + thick / 2) * w + (half_u + gap - side_len / 2) * u
        out.append(_box(c, np.abs(w) * thick + np.abs(u) * side_len, 0.0, height))
    return out, u


def _free_box(rng, layout: _Layout, kind: str, extent: float) -> tuple[np.ndarray, np.ndarray]:
    """A mast (tall, thin) or a box of varied footprint, sometimes off the ground."""
    lo, hi = layout.area_lo[:2], layout.area_hi[:2]
    if kind == "mast":
        size, z0, z1 = np.full(2, rng.uniform(8, 25)), 0.0, rng.uniform(100, 250)
    else:
        size = rng.uniform(20, max(40.0, extent / 4), 2)
        z0 = 0.0 if rng.random() > 0.15 else float(np.round(rng.uniform(15, 60)))
        z1 = z0 + rng.uniform(10, 150)
    return _box(rng.uniform(lo + size / 2, hi - size / 2), size, z0, float(np.round(z1)))


def _obstacles(rng, layout: _Layout, k: int, goal_c, goal_s, margin, extent) -> list:
    """Place k obstacles: a gate, a shield, masts and boxes; returns the shields as
    (goal index, direction behind the shield)."""
    shields, g = [], len(goal_c)
    if k >= 2 and rng.random() < 0.8:
        for _ in range(30):
            j = int(rng.integers(g))
            if layout.add(_gate(rng, goal_c[j], goal_s[j], margin), "gate"):
                break
    if len(layout.lo) < k and rng.random() < 0.8:
        walls = int(min(rng.integers(1, 4), k - len(layout.lo)))
        for _ in range(30):
            j = int(rng.integers(g))
            boxes, u = _shield(rng, goal_c[j], goal_s[j], margin, walls)
            if layout.add(boxes, "shield"):
                shields.append((j, u))
                break
    for _ in range(200 * k):
        if len(layout.lo) >= k:
            break
        kind = "mast" if rng.random() < 0.2 else "box"
        layout.add([_free_box(rng, layout, kind, extent)], kind)
    return shields if len(layout.lo) == k else None  # None: too crowded, draw another area






# --------------------------------------------------------------------------- the generator
KINDS = {"open": (MAX_OBSTACLES, MAX_TARGETS), "city": (150, 16), "town": (150, 16)}  # most obstacles, targets


def generate(rng: np.random.Generator | int, obstacles: int, targets: int | None = None,
             settings: Settings | None = None, name: str | None = None, kind: str = "open") -> Generated:
    """Draw a world + mission pair.

    Parameters
    ----------
    rng : a Generator, or a seed for ``numpy.random.default_rng``.
    obstacles : cuboids, 0..15 of the kind "open" (this module's docstring), 0..150
        buildings of the kind "city" (:mod:`uavsim.world.city`, street grids) or "town"
        (:mod:`uavsim.world.town`, irregular blocks, convex buildings off the axes, far goals).
    targets : 1..8 ("open"), 1..16 ("city"); None: drawn from ``rng``.
    settings : the mission numbers (default: the paper's); name : default the kind's.
    """
    if kind not in KINDS:
        raise ValueError(f"unknown world kind {kind!r}; choose from {', '.join(KINDS)}")
    settings = settings or Settings()
    most_obstacles, most_targets = KINDS[kind]
    seed = rng if isinstance(rng, (int, np.integer)) else None
    rng = np.random.default_rng(rng)
    if not 0 <= obstacles <= most_obstacles:
        raise ValueError(f"obstacles must be between 0 and {most_obstacles}, got {obstacles}")
    if targets is None:
        targets = int(rng.integers(1, most_targets + 1))
    if not 1 <= targets <= most_targets:
        raise ValueError(f"targets must be between 1 and {most_targets}, got {targets}")
    attempt = {"city": city.attempt, "town": town.attempt}.get(kind, _attempt)
    for _ in range(1000):  # a draw that cannot be completed starts again from a new area
        out = attempt(rng, obstacles, targets, settings)
        if out is not None:
            return Generated(name=name or ("gen" if kind == "open" else kind), seed=None if seed is None else int(seed),
                             settings=settings, **out)
    raise RuntimeError("no world found in 1000 draws")  # never seen; a bug if it happens


def _area(rng) -> tuple[np.ndarray, np.ndarray]:
    while True:
        size = np.round(rng.uniform([600, 500], [1600, 1400]) / 10) * 10
        if abs(size[0] - size[1]) >= 100:
            break
    origin = np.round(rng.uniform(-500, 500, 2) / 10) * 10 if rng.random() < 0.3 else np.zeros(2)
    top = float(np.round(rng.uniform(300, 1000) / 50) * 50)
    return np.r_[origin, 0.0], np.r_[origin + size, top]


def _goals(rng, n: int, area_lo, area_hi) -> tuple[np.ndarray, np.ndarray] | None:
    centres, sizes = [], []
    for _ in range(100 * n):
        if len(centres) == n:
            return np.array(centres), np.array(sizes)
        s = np.round(rng.uniform(40, 120, 2) / 5) * 5
        c = np.round(rng.uniform(area_lo[:2] + 60 + s / 2, area_hi[:2] - 60 - s / 2))
        if all(np.any(np.abs(c - c2) > (s + s2) / 2 + 80) for c2, s2 in zip(centres, sizes)):
            centres.append(c), sizes.append(s)
    return None


def _attempt(rng, n_obstacles: int, n_targets: int, s: Settings) -> dict | None:
    area_lo, area_hi = _area(rng)
    extent = float(np.min(area_hi[:2] - area_lo[:2]))
    goals = _goals(rng, int(rng.integers(1, min(n_targets, 3) + 1)), area_lo, area_hi)
    if goals is None:
        return None
    goal_c, goal_s = goals
    goals_lo, goals_hi = goal_c - goal_s / 2, goal_c + goal_s / 2
    layout = _Layout(area_lo, area_hi, goals_lo, goals_hi, s.margin + 10.0)
    shields = _obstacles(rng, layout, n_obstacles, goal_c, goal_s, s.margin, extent)
    if shields is None:
        return None
    obs_lo, obs_hi = np.array(layout.lo).reshape(-1, 3), np.array(layout.hi).reshape(-1, 3)
    ground = ground_boxes(obs_lo, obs_hi, s.margin)
    space = free_space(ground, area_lo, area_hi)
    if any(not space.region_labels(a, b) for a, b in zip(goals_lo, goals_hi)):
        return None
    behind = dict(shields)
    fields = [GoalField(c, ground, area_lo, area_hi) for c in goal_c]
    starts, vels, which, lengths = [], [], [], []
    for j in range(n_targets):
        g = j % len(goal_c)
        got = draw_target(rng, (goal_c[g], goal_s[g]), behind.pop(g, None), fields[g], ground, area_lo, area_hi,
                      goals_lo, goals_hi, s)
        if got is None:
            return None
        starts.append(got[0]), vels.append(got[1]), which.append(g), lengths.append(got[2])
    uav = draw_uav(rng, obs_lo, obs_hi, area_lo, area_hi)
    sensors = draw_fixed_sensors(rng, obs_lo, obs_hi, area_lo, area_hi)
    if uav is None or sensors is None:
        return None
    return dict(
        area_lo=area_lo, area_hi=area_hi, obstacle_names=tuple(layout.names), obstacle_lo=obs_lo,
        obstacle_hi=obs_hi, goal_names=tuple(f"G{i + 1}" for i in range(len(goal_c))), goal_centres=goal_c,
        goal_sizes=goal_s, target_positions=np.column_stack([starts, np.zeros(n_targets)]),
        target_velocities=np.column_stack([vels, np.zeros(n_targets)]), target_goals=np.array(which),
        route_lengths=np.array(lengths), fixed_sensors=sensors,
        **uav,
    )












# --------------------------------------------------------------------------- TOML
def world_toml(g: Generated, command: str = "") -> str:
    """The world file: area, obstacles (cuboids, or prisms over ``g.footprints``), goal regions."""
    lines = [f"# {g.source} world{f' ({command})' if command else ''}.", *(f"# {n}" for n in g.notes),
             f"# Obstacles are inflated by {g.settings.margin:g} m for ground targets "
             "(speed_max * dt / 2 + clearance).",
             f"name = {value_text(g.name)}", "", "[area]", f"min_m = {value_text(g.area_lo)}",
             f"max_m = {value_text(g.area_hi)}"]
    for k, (name, lo, hi) in enumerate(zip(g.obstacle_names, g.obstacle_lo, g.obstacle_hi)):
        lines += ["", "[[obstacles]]", f"name = {value_text(name)}"]
        if g.footprints is None:
            lines += [f"min_m = {value_text(lo)}", f"max_m = {value_text(hi)}"]
        else:
            lines += [f"footprint_m = {value_text(g.footprints[k])}", f"z_m = {value_text(np.r_[lo[2], hi[2]])}"]
    for name, c, s in zip(g.goal_names, g.goal_centres, g.goal_sizes):
        lines += ["", "[[goals]]", f"name = {value_text(name)}", f"center_m = {value_text(c)}",
                  f"size_m = {value_text(s)}"]
    return "\n".join(lines) + "\n"


def mission_toml(g: Generated, world_ref: str, command: str = "") -> str:
    """The mission file (:func:`uavsim.writer.mission_text`); ``world_ref`` is the world's
    path relative to the mission."""
    s = g.settings
    region = None
    if g.region is not None:
        region = Region2D.box(g.region[1], g.region[2]) if g.region[0] == "box" else Region2D.from_vertices(g.region[1])
    uav = replace(s.uav, start=g.uav_start, altitude=g.altitude, region=region, random_start=True)
    sizes = {name: g.manoeuvres[spec.key] for name, spec in specs(ManoeuvreConfig) if spec.key in g.manoeuvres}
    planner = PlannerConfig(manoeuvres=ManoeuvreConfig(step=uav.n_r * uav.step, **sizes),
                            fixed_sensors=FixedSensorsConfig(positions=np.column_stack([g.fixed_sensors,
                                                                                        np.zeros(len(g.fixed_sensors))])))
    top = dict(description=f"{g.source.lower()}: {len(g.obstacle_names)} obstacles, {len(g.target_goals)} targets",
               steps=s.guidance.horizon, trials=s.trials, seed=g.seed if g.seed is not None else 0, truth="planned")
    targets = [(f"T{i + 1}", np.r_[p, v], s.cov0, g.goal_names[goal])
               for i, (p, v, goal) in enumerate(zip(g.target_positions, g.target_velocities, g.target_goals))]
    reach = g.reach_fraction * s.guidance.horizon * s.dynamics.dt * s.guidance.speed_max
    comments = (f"{g.source} mission{f' ({command})' if command else ''}.", *g.notes,
                "Every setting is the declared default (the paper mission's, [Papaioannou2023, Sec. VI-A]) "
                "but the world's own.",
                f"Every goal is within {g.reach_fraction:g} x T dt v_max = {reach:g} m of free path from its targets.")
    lengths = tuple(f"free-space shortest path to the goal's centre: {length:.0f} m" for length in g.route_lengths)
    return mission_text(world_ref, top, s.dynamics, s.sensor, uav, s.guidance, s.filter, planner, targets,
                        comments, lengths)
