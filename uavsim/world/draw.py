"""What every kind of generated world shares: the settings written into its mission,
the record it is drawn into, and the draws of targets, the UAV and the fixed sensors.

Everything random comes from the one ``numpy.random.Generator`` passed in, and every
number is rounded before it is used, so a seed gives byte-identical files
(:mod:`uavsim.world.generate`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..belief import FilterConfig
from ..declare import si_array
from ..guidance.model import GuidanceConfig
from ..sensing import BearingModel
from ..targets import TARGET_KEYS, Dynamics
from ..uav import UavConfig
from ..uav.manoeuvres import default_sizes
from .model import GROUND_BAND_M, Polygons, Region2D, cuboid_halfspaces, ground_footprints, inside_polytopes
from .routes import GoalField, segment_polygon_distance

REACH_FRACTION = 0.6
TARGET_COV0 = next(spec for spec in TARGET_KEYS if spec.key == "cov0_si")


@dataclass(frozen=True, eq=False)
class Settings:
    """The settings written into every generated mission: the declared defaults (the
    paper's, [Papaioannou2023, Sec. VI-A]; :mod:`uavsim.declare`), except ``trials`` (10: a generated
    world is for a first look; ``--trials`` sets more).  A world's own UAV start, altitude,
    region, manoeuvre sizes and fixed sensors are drawn per world."""

    dynamics: Dynamics = field(default_factory=Dynamics)
    sensor: BearingModel = field(default_factory=BearingModel)
    guidance: GuidanceConfig = field(default_factory=GuidanceConfig)
    filter: FilterConfig = field(default_factory=FilterConfig)
    uav: UavConfig = field(default_factory=UavConfig)
    cov0: np.ndarray = field(default_factory=lambda: si_array(TARGET_COV0, TARGET_COV0.default))
    trials: int = 10

    @property
    def margin(self) -> float:
        """delta = v_max dt / 2 + clearance, the guidance model's per-axis inflation."""
        return self.guidance.speed_max * self.dynamics.dt / 2.0 + self.guidance.clearance

    @property
    def reach(self) -> float:
        """Longest free path allowed from a start to its goal (m)."""
        return REACH_FRACTION * self.guidance.horizon * self.dynamics.dt * self.guidance.speed_max


@dataclass(frozen=True, eq=False)
class Generated:
    """One generated world and mission (SI units, rounded as written).

    Shapes: K obstacles, G goals, N targets.  ``region`` is None, ``("box", lo, hi)``
    or ``("polygon", vertices (k, 2))``.  ``route_lengths (N,)``: free-space shortest
    path from each start to its goal's centroid.
    """

    name: str
    area_lo: np.ndarray
    area_hi: np.ndarray
    obstacle_names: tuple[str, ...]
    obstacle_lo: np.ndarray  # (K, 3)
    obstacle_hi: np.ndarray
    goal_names: tuple[str, ...]
    goal_centres: np.ndarray  # (G, 2)
    goal_sizes: np.ndarray
    target_positions: np.ndarray  # (N, 3)
    target_velocities: np.ndarray  # (N, 3)
    target_goals: np.ndarray  # (N,) int
    route_lengths: np.ndarray  # (N,)
    altitude: float
    uav_start: np.ndarray  # (3,)
    region: tuple | None
    fixed_sensors: np.ndarray  # (3, 2)
    manoeuvres: dict[str, float]
    seed: int | None = None
    settings: Settings = field(default_factory=Settings)
    footprints: tuple[np.ndarray, ...] | None = None  # convex (k, 2) per obstacle: prisms (lo, hi their boxes)
    source: str = "Generated"  # the files' first words: what made them
    notes: tuple[str, ...] = ()  # more comment lines for both files (an attribution)
    reach_fraction: float = REACH_FRACTION  # every goal within this x T dt v_max of free path from its targets


def ground_boxes(obs_lo: np.ndarray, obs_hi: np.ndarray, margin: float) -> Polygons:
    """The inflated footprints ground targets avoid (:func:`uavsim.world.ground_footprints`)
    of cuboids ``[obs_lo, obs_hi]`` ``(K, 3)``."""
    obs_lo, obs_hi = np.reshape(obs_lo, (-1, 3)), np.reshape(obs_hi, (-1, 3))
    return ground_footprints(Polygons.boxes(obs_lo[:, :2], obs_hi[:, :2]), obs_lo[:, 2], obs_hi[:, 2], margin,
                             GROUND_BAND_M)[1]


def draw_target(rng, goal, behind, field: GoalField, ground: Polygons, area_lo, area_hi, goals_lo, goals_hi,
                s: Settings):
    """A start and starting velocity for a target of ``goal = (centre, size)``:
    outside the inflated obstacles by a margin at p0 and at p1 = p0 + v0 dt, outside
    every goal region, with 100 m <= free path to the goal's centroid <= ``s.reach``.
    Candidates are drawn 32 at a time; the first that qualifies is taken."""
    for _ in range(40):
        ang = rng.uniform(-np.pi, np.pi, 32)
        if behind is not None:  # in a 60-degree cone behind the shield
            ang = np.arctan2(behind[1], behind[0]) + ang / 6
        r = rng.uniform(0.25, 0.95, 32) * s.reach
        p0 = np.round(goal[0] + r[:, None] * np.column_stack([np.cos(ang), np.sin(ang)]))
        v0 = np.where(rng.random(32)[:, None] < 0.5, 0.0, np.round(rng.uniform(-4, 4, (32, 2)), 1))
        pts = np.stack([p0, p0 + v0 * s.dynamics.dt], axis=1)  # (32, 2, 2)
        ok = np.all((pts >= area_lo[:2] + s.margin) & (pts <= area_hi[:2] - s.margin), axis=(1, 2))
        if len(ground):
            ok &= np.all(segment_polygon_distance(pts, pts, ground).min(axis=-1) >= s.margin, axis=1)
        ok &= ~np.any(np.all((pts[:, :, None] >= goals_lo) & (pts[:, :, None] <= goals_hi), axis=-1), axis=(1, 2))
        for chunk in np.array_split(np.flatnonzero(ok), max(1, int(ok.sum()) // 8)):
            length = field.lengths(p0[chunk])
            good = np.flatnonzero((length >= 100.0) & (length <= s.reach))
            if len(good):
                k = chunk[good[0]]
                return p0[k], v0[k], float(length[good[0]])
    return None


def _inside(p: np.ndarray, lo: np.ndarray, hi: np.ndarray, halfspaces=None) -> bool:
    """3D point inside a closed obstacle (touching counts, as in validation): the cuboids
    ``[lo, hi]``, or the polytopes ``halfspaces = (normals, offsets)``."""
    if not len(lo):
        return False
    return bool(inside_polytopes(p, *(halfspaces or cuboid_halfspaces(lo, hi))).any())


def _region2d(region: tuple) -> Region2D:
    return Region2D.box(region[1], region[2]) if region[0] == "box" else Region2D.from_vertices(region[1])


def draw_uav(rng, obs_lo, obs_hi, area_lo, area_hi, halfspaces=None) -> dict | None:
    """Altitude (below the tallest ground obstacle in 3 worlds of 4), operating region
    (box or convex polygon in 2 of 5), a free start in it and manoeuvre sizes to fit it.
    ``halfspaces``: the obstacles' (normals, offsets) when they are not the boxes
    ``[obs_lo, obs_hi]``."""
    tallest = float(obs_hi[:, 2].max()) if len(obs_hi) else 0.0
    if tallest >= 20 and rng.random() < 0.75:
        altitude = float(np.round(rng.uniform(0.3, 0.9) * tallest))
    else:
        altitude = float(np.round(rng.uniform(max(20.0, tallest + 5), max(150.0, tallest + 50))))
    altitude = min(altitude, float(area_hi[2]) - 10)
    region = draw_region(rng, area_lo, area_hi) if rng.random() < 0.4 else None
    if region is None:
        r_lo, r_hi = area_lo[:2], area_hi[:2]
    else:
        pts = region[1] if region[0] == "polygon" else np.array(region[1:])
        r_lo, r_hi = pts.min(axis=0), pts.max(axis=0)
    for _ in range(200):
        p = np.round(rng.uniform(r_lo, r_hi))
        start = np.r_[p, altitude]
        in_region = region is None or bool(_region2d(region).contains(p))
        if in_region and not _inside(start, obs_lo, obs_hi, halfspaces):
            return dict(altitude=altitude, uav_start=start, region=region,
                        manoeuvres=default_sizes(float(np.min(r_hi - r_lo))))
    return None


def draw_region(rng, area_lo, area_hi) -> tuple:
    """A box of 50-90% of the area per axis, or a convex polygon (5-8 vertices on an
    ellipse inscribed in such a box, at least 20 degrees apart)."""
    size = area_hi[:2] - area_lo[:2]
    frac = rng.uniform(0.5, 0.9, 2)
    lo = np.round(area_lo[:2] + rng.uniform(0, 1 - frac) * size)
    hi = np.round(lo + frac * size)
    if rng.random() < 0.5:
        return ("box", lo, hi)
    c, r = (lo + hi) / 2, (hi - lo) / 2
    while True:
        ang = np.sort(rng.uniform(0, 2 * np.pi, int(rng.integers(5, 9))))
        if np.any(np.diff(np.r_[ang, ang[0] + 2 * np.pi]) <= np.radians(20)):
            continue
        v = np.round(c + r * np.column_stack([np.cos(ang), np.sin(ang)]))
        edge = np.roll(v, -1, axis=0) - v
        if np.all(edge[:, 0] * np.roll(edge, -1, axis=0)[:, 1] - edge[:, 1] * np.roll(edge, -1, axis=0)[:, 0] > 0):
            return ("polygon", v)  # still strictly convex after rounding


def draw_fixed_sensors(rng, obs_lo, obs_hi, area_lo, area_hi, halfspaces=None) -> np.ndarray:
    """Three ground sensors near the paper's layout, jittered, outside obstacles
    (None if one finds no free place); ``halfspaces`` as for :func:`draw_uav`."""
    size = area_hi[:2] - area_lo[:2]
    out = []
    for frac in ((0.15, 0.2), (0.8, 0.2), (0.5, 0.9)):
        for tries in range(500):
            spread = 0.05 if tries < 100 else 0.5
            f = np.clip(np.array(frac) + rng.uniform(-spread, spread, 2), 0.02, 0.98)
            p = np.round(area_lo[:2] + f * size)
            if not _inside(np.r_[p, 0.0], obs_lo, obs_hi, halfspaces):
                out.append(p)
                break
        else:
            return None
    return np.array(out)
