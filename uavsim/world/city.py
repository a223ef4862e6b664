"""Random cities: guidance among dozens to hundreds of buildings.

``uavsim.world.generate.generate(rng, obstacles=K, targets=N, kind="city")`` draws a world +
mission pair of the kind "city" with :func:`attempt` (the kind "open" has a few walls,
masts and boxes).  The result is a :class:`uavsim.world.draw.Generated`, written by the
same ``world_toml`` and ``mission_toml``; everything random comes from the one Generator
passed in.

What a city holds:

* a street grid of irregular pitch: blocks of 70-190 m between streets of 26-50 m (a
  ground target's obstacles are inflated by ``v_max dt / 2 + clearance = 9`` m a side, so
  8-32 m of each street stays free), a ring road inside the area's edge, and some blocks
  merged across their street (T-junctions, superblocks);
* building blocks split into 1-6 buildings of varied footprint (setbacks of 0-10 m) and
  height (8-160 m), separated by alleys that are either closed after inflation (2-12 m)
  or open (24-36 m);
* **plazas** (empty blocks) and **courtyards** (a ring of three or four buildings round an
  open court with one 30-45 m gateway) as goal regions, parks (empty blocks), and walls
  across some streets that make **dead ends**;
* 0-150 buildings exactly as asked (walls and courtyard rings included), 1-16 targets in
  the streets, each with a goal at most ``REACH_FRACTION`` of the horizon's reach away by
  free path, checked as for the open kind (:func:`uavsim.world.generate.generate`).
"""

from __future__ import annotations

import numpy as np

from .draw import Settings, draw_fixed_sensors, draw_target, draw_uav, ground_boxes
from .routes import GoalField
from .space import free_space

BLOCK_M, STREET_M = (70.0, 190.0), (26.0, 50.0)
PER_BLOCK = 6  # most buildings one block is split into
GATEWAY_M = (30.0, 45.0)


# --------------------------------------------------------------------------- the street grid
def _lines(rng, blocks: int, start: float) -> tuple[np.ndarray, float]:
    """Block intervals ``(blocks, 2)`` along one axis, streets between them, from ``start``
    (the ring road's inner edge); returns them and the far edge of the last block."""
    widths = np.round(rng.uniform(*BLOCK_M, blocks))
    streets = np.round(rng.uniform(*STREET_M, blocks))
    streets[rng.random(blocks) < 0.15] += 20.0  # an avenue now and then
    lo = start + np.r_[0.0, np.cumsum(widths[:-1] + streets[:-1])]
    return np.column_stack([lo, lo + widths]), float(lo[-1] + widths[-1])


def _blocks(rng, need: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Area ``(lo (3,), hi (3,))`` and blocks ``(B, 2, 2)`` ([lo, hi] per block): a grid of
    at least ``need`` cells, some pairs merged across their street."""
    aspect = rng.uniform(0.55, 1.8)
    nx = max(2, int(np.ceil(np.sqrt(need * aspect))))
    ny = max(2, int(np.ceil(need / nx)))
    if nx == ny:
        nx += 1  # never square, as the open kind
    ring = np.round(rng.uniform(30.0, 55.0, 2))
    origin = np.round(rng.uniform(-500, 500, 2) / 10) * 10 if rng.random() < 0.3 else np.zeros(2)
    xs, x_end = _lines(rng, nx, origin[0] + ring[0])
    ys, y_end = _lines(rng, ny, origin[1] + ring[1])
    area_hi = np.array([x_end, y_end]) + ring
    cells = np.array([[[x[0], y[0]], [x[1], y[1]]] for x in xs for y in ys])  # (nx ny, 2, 2), index i ny + j
    alive = np.ones(len(cells), bool)
    for i in range(nx):
        for j in range(ny):
            k = i * ny + j
            if not alive[k] or rng.random() > 0.12:
                continue
            other = k + ny if (rng.random() < 0.5 and i + 1 < nx) else (k + 1 if j + 1 < ny else -1)
            if other >= 0 and alive[other] and _mergeable(cells[k], cells[other]):
                cells[k] = [np.minimum(cells[k][0], cells[other][0]), np.maximum(cells[k][1], cells[other][1])]
                alive[other] = False
    return np.r_[origin, 0.0], np.r_[area_hi, 0.0], cells[alive]


def _mergeable(a: np.ndarray, b: np.ndarray) -> bool:
    """Two cells ``[lo, hi] (2, 2)`` facing each other across a street along their whole
    side: the same x-interval (one above the other) or the same y-interval."""
    return bool(np.all(a[:, 0] == b[:, 0]) or np.all(a[:, 1] == b[:, 1]))


# --------------------------------------------------------------------------- buildings
def _height(rng) -> tuple[float, float]:
    top = float(np.round(min(rng.lognormal(np.log(25.0), 0.7), 160.0)))
    return 0.0, max(top, 8.0)


def _split(rng, lo: np.ndarray, hi: np.ndarray, k: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """``k`` building footprints in the block ``[lo, hi]`` (2,): guillotine cuts along the
    longer side with an alley (closed or open after inflation), then setbacks."""
    if k == 1:
        setback = np.round(rng.uniform(0.0, 10.0, 4))
        a, b = lo + setback[:2], hi - setback[2:]
        return [(a, b)] if np.all(b - a >= 8.0) else [(lo + 2.0, hi - 2.0)]
    axis = int(np.argmax(hi - lo))
    alley = float(np.round(rng.uniform(2.0, 12.0) if rng.random() < 0.6 else rng.uniform(24.0, 36.0)))
    k1 = int(rng.integers(1, k))
    cut = lo[axis] + (hi[axis] - lo[axis] - alley) * np.clip(k1 / k + rng.uniform(-0.1, 0.1), 0.2, 0.8)
    if (cut - lo[axis]) / k1 < 12.0 or (hi[axis] - cut - alley) / (k - k1) < 12.0:
        return []  # too thin to split so far
    hi1, lo2 = hi.copy(), lo.copy()
    hi1[axis], lo2[axis] = np.round(cut), np.round(cut) + alley
    first, second = _split(rng, lo, hi1, k1), _split(rng, lo2, hi, k - k1)
    return first + second if first and second else []


def _courtyard(rng, lo: np.ndarray, hi: np.ndarray, keep_clear: float):
    """A ring of buildings round an open court with one gateway: ``(boxes, court_lo, court_hi)``
    or None if the block is too small for a court that can hold a goal."""
    thick = np.round(rng.uniform(18.0, 30.0))
    c_lo, c_hi = lo + thick, hi - thick
    if np.any(c_hi - c_lo < 2 * keep_clear + 40.0):
        return None
    side = int(rng.integers(4))  # the gateway's side: +x, -x, +y, -y
    gate = float(np.round(rng.uniform(*GATEWAY_M)))
    walls = {0: (np.array([c_hi[0], lo[1]]), hi.copy()), 1: (lo.copy(), np.array([c_lo[0], hi[1]])),
             2: (np.array([c_lo[0], c_hi[1]]), np.array([c_hi[0], hi[1]])),
             3: (np.array([c_lo[0], lo[1]]), np.array([c_hi[0], c_lo[1]]))}
    boxes = [w for s, w in walls.items() if s != side]
    a, b = walls[side]
    axis = 1 if side < 2 else 0  # the gateway wall runs along this axis
    mid = np.round(0.5 * (c_lo[axis] + c_hi[axis]) + rng.uniform(-0.2, 0.2) * (c_hi[axis] - c_lo[axis] - gate))
    left_hi, right_lo = b.copy(), a.copy()
    left_hi[axis], right_lo[axis] = mid - gate / 2, mid + gate / 2
    boxes += [(a, left_hi), (right_lo, b)]
    # corners join the ring: the side walls run the full block, the others between them
    return [(np.round(p), np.round(q)) for p, q in boxes if np.all(q - p >= 4.0)], c_lo, c_hi


def _dead_end(rng, cells: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """A wall across the street beside a random block, from that block's side to the
    block facing it (None where no block faces it across a street)."""
    k = int(rng.integers(len(cells)))
    lo, hi = cells[k]
    side = int(rng.integers(4))  # +x, -x, +y, -y
    axis, other = side // 2, 1 - side // 2
    thick = float(np.round(rng.uniform(8.0, 15.0)))
    at = float(np.round(rng.uniform(lo[other], hi[other] - thick)))
    facing = (cells[:, 0, other] <= at) & (cells[:, 1, other] >= at + thick)
    edge = hi[axis] if side % 2 == 0 else lo[axis]
    gap = cells[:, 0, axis] - edge if side % 2 == 0 else edge - cells[:, 1, axis]
    gap = gap[facing & (gap > 0)]
    if not len(gap) or gap.min() > STREET_M[1] + 25.0:
        return None
    w_lo, w_hi = np.zeros(2), np.zeros(2)
    w_lo[other], w_hi[other] = at, at + thick
    near, far = edge + (1.0 if side % 2 == 0 else -1.0), edge + (gap.min() - 1.0) * (1 if side % 2 == 0 else -1)
    w_lo[axis], w_hi[axis] = min(near, far), max(near, far)
    return w_lo, w_hi


def _clear_of(box, goals, keep_clear: float) -> bool:
    """The footprint ``box = (lo, hi)`` keeps ``keep_clear`` from every goal ``(centre, size)``."""
    return all(np.any((box[1] <= c - z / 2 - keep_clear) | (box[0] >= c + z / 2 + keep_clear)) for c, z in goals)


# --------------------------------------------------------------------------- one draw
def attempt(rng, n_buildings: int, n_targets: int, s: Settings) -> dict | None:
    """One draw of a city: the fields of :class:`uavsim.world.draw.Generated`, or None when
    the draw cannot be completed (the caller draws again)."""
    keep_clear = s.margin + 10.0
    n_goals = int(rng.integers(1, min(n_targets, 4) + 1))
    walls = int(np.round(n_buildings * rng.uniform(0.0, 0.08))) if n_buildings >= 25 else 0
    need = n_goals + 2 + int(np.ceil((n_buildings - walls) / 2.5))
    area_lo, area_hi, cells = _blocks(rng, need)
    order = rng.permutation(len(cells))
    goal_cells, rest = order[:n_goals], order[n_goals:]
    boxes, goals, kinds = [], [], []
    for k in goal_cells:
        lo, hi = cells[k]
        court = _courtyard(rng, lo, hi, keep_clear) if rng.random() < 0.5 and n_buildings - walls >= 4 else None
        if court is not None and len(court[0]) <= n_buildings - walls - len(boxes):
            boxes += court[0]
            kinds += ["court"] * len(court[0])
            lo, hi = court[1] + keep_clear, court[2] - keep_clear
        size = np.minimum(np.round(rng.uniform(40.0, 110.0, 2) / 5) * 5, hi - lo - 10.0)
        centre = np.round(rng.uniform(lo + size / 2, hi - size / 2))
        goals.append((centre, size))
    left = n_buildings - walls - len(boxes)
    counts = _counts(rng, cells[rest], left)
    if counts is None:
        return None
    for k, c in zip(rest, counts):
        parts = next((p for p in (_split(rng, *cells[k], c) for _ in range(10)) if p), None) if c else []
        if parts is None:
            return None
        boxes += parts
        kinds += ["b"] * len(parts)
    for _ in range(50 * walls):
        if len(boxes) == n_buildings:
            break
        wall = _dead_end(rng, cells)
        if wall is not None and _clear_of(wall, goals, keep_clear):
            boxes.append(wall)
            kinds.append("wall")
    if len(boxes) != n_buildings:
        return None
    return _finish(rng, boxes, kinds, goals, area_lo, area_hi, n_targets, s)


def _counts(rng, cells: np.ndarray, total: int) -> np.ndarray | None:
    """Buildings per block summing to ``total``: each block 0 (a park) or 1..PER_BLOCK, by
    area, spread over the blocks in a random order."""
    cap = np.clip((np.prod(cells[:, 1] - cells[:, 0], axis=1) / 3500.0).astype(int), 1, PER_BLOCK)
    if cap.sum() < total:
        return None
    counts = np.zeros(len(cells), int)
    while counts.sum() < total:
        open_ = np.flatnonzero(counts < cap)
        pick = rng.choice(open_, size=min(len(open_), total - counts.sum()), replace=False)
        counts[pick] += 1
    return counts


def _finish(rng, boxes, kinds, goals, area_lo, area_hi, n_targets: int, s: Settings) -> dict | None:
    """Heights, goals checked clear, targets, UAV and fixed sensors (as the open kind).
    Buildings are named by kind: ``b`` in blocks, ``court`` round a courtyard, ``wall``
    across a street."""
    heights = [_height(rng) for _ in boxes]
    obs_lo = np.array([[*b[0], h[0]] for b, h in zip(boxes, heights)]).reshape(-1, 3)
    obs_hi = np.array([[*b[1], h[1]] for b, h in zip(boxes, heights)]).reshape(-1, 3)
    tallest = float(obs_hi[:, 2].max()) if len(obs_hi) else 0.0
    area_hi = area_hi.copy()
    area_hi[2] = float(np.round(max(300.0, tallest + 100.0) / 50) * 50)
    goal_c = np.array([g[0] for g in goals])
    goal_s = np.array([g[1] for g in goals])
    if np.any(goal_s < 30.0):
        return None
    goals_lo, goals_hi = goal_c - goal_s / 2, goal_c + goal_s / 2
    keep_clear = s.margin + 10.0
    if len(obs_lo) and np.any(np.all((obs_lo[:, None, :2] < goals_hi + keep_clear)
                                     & (obs_hi[:, None, :2] > goals_lo - keep_clear), axis=-1)):
        return None
    ground = ground_boxes(obs_lo, obs_hi, s.margin)
    space = free_space(ground, area_lo, area_hi)
    if any(not space.region_labels(a, b) for a, b in zip(goals_lo, goals_hi)):
        return None
    fields = [GoalField(c, ground, area_lo, area_hi) for c in goal_c]
    starts, vels, which, lengths = [], [], [], []
    for j in range(n_targets):
        g = j % len(goal_c)
        got = draw_target(rng, (goal_c[g], goal_s[g]), None, fields[g], ground, area_lo, area_hi, goals_lo,
                      goals_hi, s)
        if got is None:
            return None
        starts.append(got[0]), vels.append(got[1]), which.append(g), lengths.append(got[2])
    uav = draw_uav(rng, obs_lo, obs_hi, area_lo, area_hi)
    sensors = draw_fixed_sensors(rng, obs_lo, obs_hi, area_lo, area_hi)
    if uav is None or sensors is None:
        return None
    names = tuple(f"{kind}{i + 1}" for i, kind in enumerate(kinds))
    return dict(
        area_lo=area_lo, area_hi=area_hi, obstacle_names=names, obstacle_lo=obs_lo, obstacle_hi=obs_hi,
        goal_names=tuple(f"G{i + 1}" for i in range(len(goal_c))), goal_centres=goal_c, goal_sizes=goal_s,
        target_positions=np.column_stack([starts, np.zeros(n_targets)]),
        target_velocities=np.column_stack([vels, np.zeros(n_targets)]), target_goals=np.array(which),
        route_lengths=np.array(lengths), fixed_sensors=sensors, **uav,
    )
