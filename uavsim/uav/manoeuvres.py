"""Pre-computed UAV manoeuvres ([Papaioannou2023] Sec. VI-B, Fig. 3).

Closed loops (zig-zag, square, pentagon, circle) whose first waypoint is placed at the
UAV's start, shifted as little as needed to lie inside the operating region; the UAV
flies straight to the loop's first waypoint if shifted, then round the loop, ``step``
metres per time step, for as long as the mission lasts.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..declare import SettingError, setting
from ..mission import Mission
from ..world import Region2D, World
from .grid import OneUav, UavConfig

MANOEUVRES = ("zigzag", "square", "pentagon", "circle")


# A manoeuvre's size as a fraction of the operating region's (or area's) smaller side,
# rounded to 5 m: on the paper's 1 km area 300, 120, 150, 90, 80 m.
SIZE_FRACTIONS = {"zigzag_length_m": 0.3, "zigzag_width_m": 0.12, "square_side_m": 0.15,
                  "pentagon_radius_m": 0.09, "circle_radius_m": 0.08}


def default_sizes(extent: float) -> dict[str, float]:
    """The manoeuvres' sizes (file keys, m) for a region whose smaller side is ``extent`` m."""
    return {k: max(5.0, float(np.round(f * extent / 5) * 5)) for k, f in SIZE_FRACTIONS.items()}


def _size(key: str, doc: str):
    return setting(key, kind="number", unit="m", lo=1, hi=1e5, doc=doc,
                   derived=f"{SIZE_FRACTIONS[key]:g} of the operating region's (area's) smaller side, to 5 m")


@dataclass(frozen=True)
class ManoeuvreConfig:
    """Pre-computed manoeuvres of Sec. VI-B (Fig. 3).  The paper publishes no sizes;
    the mission chooses them.  ``step`` is the distance flown per time step."""

    step: float = setting("step_m", kind="number", unit="m", lo=0.01, hi=1000,
                          derived="uav.n_r x uav.step_m", doc="distance flown per time step")
    zigzag_length: float = _size("zigzag_length_m", "length of the zig-zag")
    zigzag_width: float = _size("zigzag_width_m", "width of the zig-zag")
    zigzag_legs: int = setting("zigzag_legs", 4, lo=1, hi=100, doc="diagonal legs of the zig-zag")
    square_side: float = _size("square_side_m", "side of the square")
    pentagon_radius: float = _size("pentagon_radius_m", "circumradius of the pentagon")
    circle_radius: float = _size("circle_radius_m", "radius of the circle")



def manoeuvre_loop(name: str, cfg: ManoeuvreConfig) -> np.ndarray:
    """``(k, 2)`` waypoints of a closed loop in local coordinates, first waypoint at 0.

    zigzag: ``legs`` diagonal legs over ``length`` (x) between y = 0 and y = ``width``,
    then back along the same legs; square: side ``side``; pentagon: regular, circumradius
    ``radius``; circle: radius ``radius`` as a 72-gon (5 deg chords).  Counter-clockwise.
    """
    if name == "zigzag":
        x = np.linspace(0.0, cfg.zigzag_length, cfg.zigzag_legs + 1)
        y = np.where(np.arange(cfg.zigzag_legs + 1) % 2 == 1, cfg.zigzag_width, 0.0)
        out = np.column_stack([x, y])
        return np.vstack([out, out[-2:0:-1]])
    sides, radius = {"square": (4, cfg.square_side / np.sqrt(2.0)), "pentagon": (5, cfg.pentagon_radius),
                     "circle": (72, cfg.circle_radius)}[name]
    ang = -np.pi / 2 - np.pi / sides + 2.0 * np.pi * np.arange(sides) / sides  # bottom edge horizontal
    ring = radius * np.column_stack([np.cos(ang), np.sin(ang)])
    return ring - ring[0]


def place_loop(loop: np.ndarray, start: np.ndarray, fits) -> np.ndarray | None:
    """The loop translated to begin at ``start (2,)``, or moved the least distance that
    makes ``fits(placed)`` true, searching outwards on a 5 m grid of shifts up to 500 m.
    None if it fits nowhere there."""
    r = np.arange(0.0, 500.0 + 1e-9, 5.0)
    shifts = np.stack(np.meshgrid(np.r_[-r[:0:-1], r], np.r_[-r[:0:-1], r]), -1).reshape(-1, 2)
    shifts = shifts[np.argsort(np.linalg.norm(shifts, axis=1), kind="stable")]
    for shift in shifts:
        placed = loop + start + shift
        if fits(placed):
            return placed
    return None


class Route:
    """A manoeuvre flown at constant speed: ``position(k)`` after k steps (k >= 0)."""

    def __init__(self, start: np.ndarray, loop: np.ndarray, step: float, altitude: float):
        self.start, self.loop, self.step, self.altitude = start[:2], loop, step, altitude
        closed = np.vstack([loop, loop[:1]])
        self.seg = np.diff(closed, axis=0)
        self.cum = np.r_[0.0, np.cumsum(np.linalg.norm(self.seg, axis=1))]
        self.approach = float(np.linalg.norm(loop[0] - self.start))

    def position(self, k: int) -> np.ndarray:
        s = k * self.step
        if s < self.approach:
            xy = self.start + (self.loop[0] - self.start) * (s / self.approach)
        else:
            s = (s - self.approach) % self.cum[-1]
            i = int(np.searchsorted(self.cum, s, side="right") - 1)
            xy = self.loop[i] + self.seg[i] * ((s - self.cum[i]) / (self.cum[i + 1] - self.cum[i]))
        return np.array([xy[0], xy[1], self.altitude])


def manoeuvre_route(name: str, start: np.ndarray, cfg: ManoeuvreConfig, uav: UavConfig, world: World) -> Route:
    """Place manoeuvre ``name`` at (or as near as possible to) the start: inside the
    operating region (or area), its loop and the approach leg clear of obstacles at the
    UAV's altitude.  A loop that fits nowhere is a mission error."""
    region = uav.region or Region2D.box(world.area_lo[:2], world.area_hi[:2])
    h = uav.altitude

    def fits(placed):
        ring = np.column_stack([np.vstack([placed, placed[:1]]), np.full(len(placed) + 1, h)])
        leg = np.array([[start[0], start[1], h], ring[0]])
        pts = np.vstack([ring, leg])
        ends = np.r_[np.arange(len(ring) - 1), len(ring)]
        return bool(region.contains(placed).all() and not world.segment_blocked(pts[ends], pts[ends + 1]).any())

    placed = place_loop(manoeuvre_loop(name, cfg), start[:2], fits)
    if placed is None:
        raise SettingError("planner.manoeuvres",
                           f"the {name} manoeuvre fits nowhere in the operating region clear of obstacles")
    return Route(start, placed, cfg.step, h)


class Manoeuvre(OneUav):
    """The policy that flies one manoeuvre from its start (see module docstring); the
    UAV's own sensor."""

    def __init__(self, name: str, mission: Mission):
        super().__init__(mission)
        self.name = name
        self.route: Route | None = None

    def reset(self, rng: np.random.Generator) -> None:
        super().reset(rng)
        m = self.m
        self.route = manoeuvre_route(self.name, self.position, m.planner.manoeuvres, m.uav, m.world)

    def act(self, t: int, belief, action: int | None = None, forecast: list | None = None):
        if action is not None:
            raise ValueError(f"the {self.name} manoeuvre takes no actions")
        self.position = self.route.position(t + 1)
        return None, None
