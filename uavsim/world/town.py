"""Random towns: irregular blocks of buildings off the axes, goals at the edge of the horizon's reach.

``uavsim.world.generate.generate(rng, obstacles=K, targets=N, kind="town")`` draws a world
+ mission pair of the kind "town" with :func:`attempt`: what the street grids of the kind
"city" (:mod:`uavsim.world.city`) leave easy, harder.

* **Irregular blocks.**  The streets are the edges of a Voronoi diagram of points spread
  over the area (a jittered lattice, 90-170 m apart); each cell less a street's half-width
  (11-22 m: streets of 22-44 m, so 4-26 m stay free once both sides are inflated by the
  guidance's 9 m) is a block: a convex polygon whose sides run at every angle.
* **Buildings off the axes.**  A block holds 1-4 convex buildings, cut by chords in
  random directions with an alley between them (2-12 m, closed once inflated, or 24-36 m,
  open), corners sharper than 60 degrees cut off; prisms over convex footprints
  (``footprint_m``), 8-160 m tall.
* **Long detours.**  Some street segments are closed by a wall building across them (a
  dead end), so the shortest path leaves the straight line by more.
* **Far goals.**  Some cells are left open as plazas, and each holds an axis-aligned goal
  region; every target starts at rest on free ground (a street), with its goal
  ``REACH[0]-REACH[1]`` of the horizon's straight reach ``T dt v_max`` away by free path
  (:class:`uavsim.world.routes.GoalField`): a plan needs nearly all of its horizon.

Everything random comes from the one Generator passed in (:mod:`uavsim.world.generate`).
"""

from __future__ import annotations

import numpy as np

from .draw import Settings, draw_fixed_sensors, draw_uav
from .model import Polygons, convex_ccw, prism_halfspaces
from .routes import GoalField

REACH = (0.9, 1.0)  # fraction of T dt v_max between a target's start and its goal, by free path
PITCH_M, HALF_STREET_M = (90.0, 170.0), (11.0, 22.0)
WALL_SHARE = 0.06  # of the buildings: walls across streets


def _seeds(rng, lo: np.ndarray, hi: np.ndarray, cells: int) -> np.ndarray:
    """``(k, 2)`` Voronoi seeds: a lattice of about ``cells`` points over ``[lo, hi]``,
    each jittered by up to 40% of its pitch."""
    size = hi - lo
    pitch = float(np.sqrt(size.prod() / cells))
    nx, ny = (np.maximum(np.round(size / pitch), 2)).astype(int)
    xs, ys = lo[0] + (np.arange(nx) + 0.5) * size[0] / nx, lo[1] + (np.arange(ny) + 0.5) * size[1] / ny
    grid = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
    return grid + rng.uniform(-0.4, 0.4, grid.shape) * (size / [nx, ny])


def _cells(seeds: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> list:
    """The Voronoi cells of ``seeds`` clipped to ``[lo, hi]``, as shapely Polygons: the
    seeds mirrored across the four sides bound every cell."""
    import shapely
    from scipy.spatial import Voronoi

    mirrored = [seeds, *(np.column_stack([2 * b - seeds[:, 0], seeds[:, 1]]) for b in (lo[0], hi[0])),
                *(np.column_stack([seeds[:, 0], 2 * b - seeds[:, 1]]) for b in (lo[1], hi[1]))]
    vor = Voronoi(np.vstack(mirrored))
    box = shapely.box(*lo, *hi)
    out = []
    for k in range(len(seeds)):
        region = vor.regions[vor.point_region[k]]
        out.append(shapely.Polygon(vor.vertices[region]).convex_hull.intersection(box))
    return out


def _ring(poly) -> np.ndarray | None:
    """The counter-clockwise convex vertices ``(k, 2)`` of a polygon, rounded to 0.1 m, or
    None when what is left is not strictly convex (a sliver)."""
    import shapely

    if poly.is_empty or poly.area < 50.0:
        return None
    ring = np.round(np.asarray(shapely.geometry.polygon.orient(poly.convex_hull, 1.0).exterior.coords)[:-1], 1)
    keep = np.r_[True, np.any(np.diff(ring, axis=0) != 0, axis=1)]
    ring = ring[keep]
    d, e = np.roll(ring, -1, 0) - ring, np.roll(ring, -2, 0) - np.roll(ring, -1, 0)
    turn = d[:, 0] * e[:, 1] - d[:, 1] * e[:, 0]
    ring = ring[np.roll(turn, 1) > 1e-6]  # drop corners that rounding made straight
    ring = _blunt(ring) if len(ring) >= 3 else ring
    return ring if len(ring) >= 3 and convex_ccw(ring) == "" else None


def _blunt(ring: np.ndarray, sharpest: float = np.radians(60.0), cut: float = 4.0) -> np.ndarray:
    """A convex ring ``(k, 2)`` with every corner sharper than ``sharpest`` cut off ``cut``
    m from its tip (less on a short side): pushed out by the guidance's margin, such a
    corner would reach ``margin / sin(angle / 2)`` into the street."""
    out = []
    for i, v in enumerate(ring):
        a, b = ring[i - 1] - v, ring[(i + 1) % len(ring)] - v
        angle = np.arccos(np.clip(a @ b / (np.linalg.norm(a) * np.linalg.norm(b)), -1.0, 1.0))
        if angle < sharpest:
            c = min(cut, 0.3 * min(np.linalg.norm(a), np.linalg.norm(b)))  # the new corners: 90 + angle / 2 degrees
            out += [v + c * a / np.linalg.norm(a), v + c * b / np.linalg.norm(b)]
        else:
            out.append(v)
    return np.round(np.array(out), 1)


def _split(rng, block, count: int) -> list:
    """``count`` convex buildings of a convex block: the largest part cut, again and again,
    by a chord in a random direction near its centre, with an alley of 2-12 m (closed once
    inflated) or 24-36 m (open) between the two sides."""
    import shapely

    parts = [block]
    for _ in range(count - 1):
        parts.sort(key=lambda p: -p.area)
        big = parts.pop(0)
        angle = rng.uniform(0, np.pi)
        n, t = np.array([np.cos(angle), np.sin(angle)]), np.array([-np.sin(angle), np.cos(angle)])
        c = np.asarray(big.centroid.coords[0]) + rng.uniform(-0.2, 0.2, 2) * np.sqrt(big.area)
        alley = rng.uniform(2.0, 12.0) if rng.random() < 0.6 else rng.uniform(24.0, 36.0)
        far = 10 * np.sqrt(big.area)
        for side in (1, -1):  # the half-plane beyond the alley on each side, as a large rectangle
            near = c + side * alley / 2 * n
            half = shapely.Polygon([near - far * t, near + far * t, near + far * t + side * far * n,
                                    near - far * t + side * far * n])
            parts.append(big.intersection(half))
    return [p for p in parts if not p.is_empty]


def _wall(rng, cell_a, cell_b, half: float):
    """A wall across the street between two neighbouring cells: the middle of their shared
    Voronoi edge, 8-15 m long along it, as wide as the street (None if they share none)."""
    import shapely

    edge = cell_a.intersection(cell_b)
    if edge.geom_type != "LineString" or edge.length < 30.0:
        return None
    a, b = np.asarray(edge.coords[0]), np.asarray(edge.coords[-1])
    t = (b - a) / np.linalg.norm(b - a)
    n = np.array([-t[1], t[0]])
    mid, thick = a + rng.uniform(0.3, 0.7) * (b - a), rng.uniform(8.0, 15.0)
    return shapely.Polygon([mid + s * thick / 2 * t + r * (half + 1.0) * n for s, r in ((-1, -1), (1, -1), (1, 1),
                                                                                         (-1, 1))])


def _goal(rng, cell, half: float, keep_clear: float) -> tuple[np.ndarray, np.ndarray] | None:
    """An axis-aligned goal region in a plaza cell, 30-100 m a side and ``keep_clear`` from
    the cell's inset edge (where the buildings across the street begin)."""
    import shapely

    inner = cell.buffer(-(half + keep_clear), join_style="mitre")
    if inner.is_empty or inner.area < 900.0:
        return None
    c = np.asarray(inner.centroid.coords[0])
    for _ in range(20):
        size = np.round(rng.uniform(30.0, 100.0, 2) / 5) * 5
        box = shapely.box(*np.round(c - size / 2), *np.round(c + size / 2))
        if inner.contains(box):
            return np.round(c), size
    return None


def attempt(rng, n_buildings: int, n_targets: int, s: Settings) -> dict | None:
    """One draw of a town: the fields of :class:`uavsim.world.draw.Generated`, or None when
    the draw cannot be completed (the caller draws again)."""
    import shapely

    n_goals = int(rng.integers(1, min(n_targets, 4) + 1))
    walls = int(np.round(n_buildings * WALL_SHARE)) if n_buildings >= 20 else 0
    blocks = int(np.ceil((n_buildings - walls) / 2.5)) if n_buildings else 0
    cells_wanted = blocks + n_goals + 2
    pitch = rng.uniform(*PITCH_M)
    straight = s.guidance.horizon * s.dynamics.dt * s.guidance.speed_max
    side = pitch * np.sqrt(cells_wanted) * np.array([rng.uniform(0.8, 1.25), 1.0])
    area_lo, area_hi = np.zeros(2), np.round(np.maximum(side, 0.85 * straight) / 10) * 10  # room for far goals
    cells = _cells(_seeds(rng, area_lo, area_hi, cells_wanted), area_lo, area_hi)
    half = rng.uniform(*HALF_STREET_M, len(cells))
    keep_clear = s.margin + 10.0
    roomy = rng.permutation(np.flatnonzero([c.area >= 8000.0 for c in cells]))
    goals = [(k, g) for k in roomy[:n_goals] if (g := _goal(rng, cells[k], half[k], keep_clear)) is not None]
    if len(goals) < n_goals:
        return None
    taken = {k for k, _ in goals}
    built = [k for k in rng.permutation(len(cells)) if k not in taken]
    counts = _counts(rng, len(built), n_buildings - walls)
    if counts is None:
        return None
    shapes, kinds = [], []
    for k, c in zip(built, counts):
        if not c:
            continue  # an open square, not a goal
        block = cells[k].buffer(-half[k], join_style="mitre")
        for part in _split(rng, block, c):
            shapes.append(part)
            kinds.append("b")
    goal_boxes = [shapely.box(*(c - z / 2), *(c + z / 2)) for _, (c, z) in goals]
    for _ in range(40 * walls):
        if kinds.count("wall") == walls:
            break
        a, b = rng.choice(len(cells), 2, replace=False)
        wall = _wall(rng, cells[a], cells[b], max(half[a], half[b]))
        if wall is not None and not any(wall.buffer(keep_clear).intersects(box) for box in goal_boxes):
            shapes.append(wall)
            kinds.append("wall")
    rings = [_ring(p.intersection(shapely.box(*area_lo, *area_hi))) for p in shapes]
    if any(r is None for r in rings) or len(rings) != n_buildings:
        return None
    return _finish(rng, rings, kinds, [g for _, g in goals], area_lo, area_hi, n_targets, s)


def _counts(rng, blocks: int, total: int) -> np.ndarray | None:
    """Buildings per block summing to ``total``: 0 (an open square, in one block of ten)
    or 1-4."""
    if total == 0:
        return np.zeros(blocks, int)
    open_ = rng.random(blocks) < 0.1
    if (~open_).sum() * 4 < total or not (~open_).any():
        return None
    counts = np.where(open_, 0, 1)
    while counts.sum() > total:
        counts[rng.choice(np.flatnonzero(counts > 0))] -= 1
    while counts.sum() < total:
        counts[rng.choice(np.flatnonzero(~open_ & (counts < 4)))] += 1
    return counts


def _finish(rng, rings, kinds, goals, area_lo, area_hi, n_targets: int, s: Settings) -> dict | None:
    """Heights, targets on the streets with far goals, UAV and fixed sensors."""
    top = [float(max(np.round(min(rng.lognormal(np.log(25.0), 0.7), 160.0)), 8.0)) for _ in rings]
    polys = Polygons.from_list(rings) if rings else Polygons.boxes(np.zeros((0, 2)), np.zeros((0, 2)))
    z = np.column_stack([np.zeros(len(rings)), top]).reshape(-1, 2)
    area3_lo = np.r_[area_lo, 0.0]
    area3_hi = np.r_[area_hi, float(np.round(max(300.0, max(top, default=0.0) + 100.0) / 50) * 50)]
    ground = polys.inflated(s.margin)
    centres = np.array([g[0] for g in goals])
    fields = [GoalField(c, ground, area_lo, area_hi) for c in centres]
    candidates = rng.uniform(area_lo + s.margin, area_hi - s.margin, (64 * n_targets, 2)).round()
    clear = ~ground.inflated(1.0).contains(candidates).any(axis=-1) if len(rings) else np.ones(len(candidates), bool)
    lo, hi = centres - np.array([g[1] for g in goals]) / 2, centres + np.array([g[1] for g in goals]) / 2
    clear &= ~np.any(np.all((candidates[:, None] >= lo) & (candidates[:, None] <= hi), axis=-1), axis=1)
    candidates = candidates[clear]
    lengths = np.column_stack([f.lengths(candidates) for f in fields])
    straight = s.guidance.horizon * s.dynamics.dt * s.guidance.speed_max
    far = (lengths >= REACH[0] * straight) & (lengths <= REACH[1] * straight)
    starts, which, route = [], [], []
    for k in np.flatnonzero(far.any(axis=1))[:n_targets]:
        g = int(rng.choice(np.flatnonzero(far[k])))
        starts.append(candidates[k]), which.append(g), route.append(lengths[k, g])
    if len(starts) < n_targets:
        return None
    obs_lo = np.column_stack([polys.lo, z[:, 0]]).reshape(-1, 3)
    obs_hi = np.column_stack([polys.hi, z[:, 1]]).reshape(-1, 3)
    halfspaces = prism_halfspaces(polys, z[:, 0], z[:, 1]) if len(rings) else None
    uav = draw_uav(rng, obs_lo, obs_hi, area3_lo, area3_hi, halfspaces)
    sensors = draw_fixed_sensors(rng, obs_lo, obs_hi, area3_lo, area3_hi, halfspaces)
    if uav is None or sensors is None:
        return None
    names = tuple(f"{kind}{i + 1}" for i, kind in enumerate(kinds))
    return dict(
        area_lo=area3_lo, area_hi=area3_hi, obstacle_names=names, obstacle_lo=obs_lo, obstacle_hi=obs_hi,
        goal_names=tuple(f"G{i + 1}" for i in range(len(goals))), goal_centres=centres,
        goal_sizes=np.array([g[1] for g in goals]), target_positions=np.column_stack([starts, np.zeros(n_targets)]),
        target_velocities=np.zeros((n_targets, 3)), target_goals=np.array(which), route_lengths=np.array(route),
        fixed_sensors=sensors, footprints=tuple(rings), reach_fraction=REACH[1], **uav,
    )
