"""Shortest collision-free ground routes among inflated obstacle footprints.

A ground target must stay outside the open rectangles of :func:`uavsim.world.ground_footprints`
(the obstacles inflated by ``delta = v_max dt / 2 + clearance``) and inside the area.  The
shortest path in that free space is a polyline that bends only at rectangle corners, so
it is found exactly on the **visibility graph**: nodes are the start, the goal and every
rectangle corner that lies in the area and outside the other rectangles; an edge joins
two nodes when the open segment between them misses every open rectangle; Dijkstra on
the edge lengths gives the route.

Conventions (those of :class:`uavsim.world.FreeSpace`, so both agree on what connects):

* a route may run along a rectangle's edge or round its corner (the rectangles are open);
* where two closed rectangles touch (at a corner or along an edge, their interiors
  apart) the passage between them has zero width and is closed: a segment through such a
  pinch is not an edge, and a corner lying on one is not a node;
* a start (goal) inside a rectangle, e.g. inside a safety margin, may leave (enter) it
  straight: for edges at that node the rectangles containing it are ignored.

Geometric ties (a segment exactly grazing a corner) are decided with a tolerance of
``1e-9`` of the area's size, so a grazing segment counts as clear.

**Distinct routes.**  A route that passes an obstacle with the obstacle on its left
(``turn = +1``) or right (``-1``) belongs to a different homotopy class from one passing
it on the other side.  A ray from the obstacle's centre through the route's point nearest
to it, out to the area boundary, is crossed by the route; a route forbidden to touch that
ray passes the obstacle the other way (the area minus obstacle and ray is simply
connected).  :func:`distinct_routes` finds the shortest route, then, best-first like
Lawler's k-best scheme, the shortest routes with one more such barrier for each obstacle,
keeping those that pass some obstacle on a side no earlier route did.  Each route lists,
per obstacle, the face it passes on and the turn.

Shapes: rectangles ``lo, hi (n, 2)``, points ``(2,)``, routes ``(m, 2)``.
"""

from __future__ import annotations

import heapq
from dataclasses import dataclass

import numpy as np
from scipy.sparse import csgraph, csr_matrix

FACES = ("+x", "-x", "+y", "-y")  # the order of uavsim.guidance.model.FACE_NORMALS
REL_TOL = 1e-9


@dataclass(frozen=True)
class Passage:
    """How a route passes one obstacle.

    Attributes
    ----------
    obstacle : index into the rectangles.
    face : 0..3 (+x, -x, +y, -y): the face the route is outside of where it comes
        closest to the obstacle's centre (at a corner, the first of the two in that order).
    turn : +1 the obstacle is on the route's left (the route goes round it anticlockwise),
        -1 on its right.
    point : (x, y) of the route's point closest to the obstacle's centre.
    touching : the route touches the (inflated) obstacle: runs along it or bends at a corner.
    """

    obstacle: int
    face: int
    turn: int
    point: tuple[float, float]
    touching: bool


@dataclass(frozen=True, eq=False)
class Route:
    """A polyline ``points (m, 2)`` from start to goal, its ``length`` (m) and how it
    passes every obstacle (in order along the route)."""

    points: np.ndarray
    length: float
    passes: tuple[Passage, ...]

    def at(self, s: np.ndarray) -> np.ndarray:
        """``(len(s), 2)`` points at arc lengths ``s`` from the start (clipped to the route)."""
        seg = np.linalg.norm(np.diff(self.points, axis=0), axis=1)
        cum = np.r_[0.0, np.cumsum(seg)]
        return np.column_stack([np.interp(s, cum, self.points[:, k]) for k in range(2)])

    def sample(self, n: int) -> np.ndarray:
        """``(n, 2)`` points at equal arc-length spacing, start and goal included."""
        return self.at(np.linspace(0.0, self.length, n))

    @property
    def sides(self) -> dict[int, int]:
        """Obstacle index -> the face it is passed on (0..3 = +x, -x, +y, -y), for every obstacle."""
        return {p.obstacle: p.face for p in self.passes}


# --------------------------------------------------------------------------- segment tests
def _clip(p0, p1, lo, hi, closed: bool) -> np.ndarray:
    """(..., n) bool: segment ``p0 -> p1 (..., 2)`` meets box n (both open or both closed).

    Slab clipping: on axis k the segment is inside for s between ``(lo - p0) / d`` and
    ``(hi - p0) / d``; a segment parallel to an axis is inside for all s or none.
    """
    p0, d = p0[..., None, :], (p1 - p0)[..., None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        ta, tb = (lo - p0) / d, (hi - p0) / d
    inside = (p0 >= lo) & (p0 <= hi) if closed else (p0 > lo) & (p0 < hi)
    par = d == 0
    t_in = np.where(par, np.where(inside, -np.inf, np.inf), np.minimum(ta, tb)).max(axis=-1)
    t_out = np.where(par, np.where(inside, np.inf, -np.inf), np.maximum(ta, tb)).min(axis=-1)
    s_lo, s_hi = np.maximum(t_in, 0.0), np.minimum(t_out, 1.0)
    return s_lo <= s_hi if closed else s_lo < s_hi


def _cross(u, v):
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def _point_segment_distance(p, a, b) -> np.ndarray:
    ab = b - a
    den = np.einsum("...k,...k->...", ab, ab)
    t = np.clip(np.einsum("...k,...k->...", p - a, ab) / np.where(den > 0, den, 1.0), 0.0, 1.0)
    return np.linalg.norm(a + t[..., None] * ab - p, axis=-1)


def segment_distance(a0, a1, b0, b1) -> np.ndarray:
    """(...,) distance between closed segments ``a0 a1`` and ``b0 b1`` (broadcast).

    Zero when they cross; otherwise the nearest pair involves an endpoint of one of them.
    """
    u, v = a1 - a0, b1 - b0
    crossing = (_cross(u, b0 - a0) * _cross(u, b1 - a0) < 0) & (_cross(v, a0 - b0) * _cross(v, a1 - b0) < 0)
    ends = np.stack(np.broadcast_arrays(
        _point_segment_distance(a0, b0, b1), _point_segment_distance(a1, b0, b1),
        _point_segment_distance(b0, a0, a1), _point_segment_distance(b1, a0, a1)))
    return np.where(crossing, 0.0, ends.min(axis=0))


def segment_box_distance(p0, p1, lo, hi) -> np.ndarray:
    """(..., n) distance between the closed segment ``p0 -> p1 (..., 2)`` and closed box n.

    Zero when they meet; otherwise the nearest pair involves a segment end or a box corner.
    """
    corners = np.stack([lo, np.column_stack([hi[:, 0], lo[:, 1]]), hi, np.column_stack([lo[:, 0], hi[:, 1]])], 1)
    to_box = [np.linalg.norm(np.maximum(0.0, np.maximum(lo - q[..., None, :], q[..., None, :] - hi)), axis=-1)
              for q in (p0, p1)]
    to_seg = _point_segment_distance(corners, p0[..., None, None, :], p1[..., None, None, :]).min(axis=-1)
    dist = np.minimum(np.minimum(*to_box), to_seg)
    return np.where(_clip(p0, p1, lo, hi, closed=True), 0.0, dist)


def faces_along(points: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """(..., n) int: per point and rectangle, the face (0..3 = +x, -x, +y, -y) with the
    largest outward clearance, the natural face to fix for that point in Eq. (8d)."""
    p = np.asarray(points, dtype=float)[..., None, :2]
    clearance = np.stack([p[..., 0] - hi[:, 0], lo[:, 0] - p[..., 0], p[..., 1] - hi[:, 1], lo[:, 1] - p[..., 1]], -1)
    return np.argmax(clearance, axis=-1)


# --------------------------------------------------------------------------- the graph
def pinches(lo: np.ndarray, hi: np.ndarray, tol: float = 0.0, skip_last: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Where two closed rectangles touch with their interiors apart (within ``tol``):
    each pinch is a point or an axis-aligned segment, returned as segments ``(a, b)``.
    Pairs among the last ``skip_last`` rectangles are left out."""
    i, j = np.triu_indices(len(lo), 1)
    keep = i < len(lo) - skip_last
    i, j = i[keep], j[keep]
    a, b = np.maximum(lo[i], lo[j]), np.minimum(hi[i], hi[j])
    overlap = b - a
    touch = np.all(overlap >= -tol, axis=1) & (overlap.min(axis=1) <= tol)
    return a[touch], b[touch]


@dataclass(frozen=True, eq=False)
class _Scene:
    """The rectangles, then four open rectangles framing the area (its outside)."""

    lo: np.ndarray  # (n + 4, 2)
    hi: np.ndarray
    n: int  # real rectangles (the first n)
    area_lo: np.ndarray
    area_hi: np.ndarray
    tol: float
    walls: tuple[np.ndarray, np.ndarray]  # closed segments nothing may touch: pinches (+ barriers)


def _scene(lo, hi, area_lo, area_hi) -> _Scene:
    lo, hi = np.reshape(lo, (-1, 2)).astype(float), np.reshape(hi, (-1, 2)).astype(float)
    a, b = np.asarray(area_lo, dtype=float)[:2], np.asarray(area_hi, dtype=float)[:2]
    size = float(np.max(b - a))
    tol, big = REL_TOL * size, 2.0 * size + np.abs(np.r_[a, b]).max()
    # left, right (full height), bottom, top (area width): a rectangle touching the area's
    # boundary closes the passage there, like two touching rectangles
    frame_lo = np.array([[a[0] - big, a[1] - big], [b[0], a[1] - big], [a[0], a[1] - big], [a[0], b[1]]])
    frame_hi = np.array([[a[0], b[1] + big], [b[0] + big, b[1] + big], [b[0], a[1]], [b[0], b[1] + big]])
    all_lo, all_hi = np.vstack([lo, frame_lo]), np.vstack([hi, frame_hi])
    return _Scene(all_lo, all_hi, len(lo), a, b, tol, pinches(all_lo, all_hi, tol, skip_last=4))


def _nodes(scene: _Scene, terminals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Nodes ``(N, 2)``: the terminals (start, goal), then the usable rectangle corners; and
    each node's tangent sign ``(N,)``: +1 for a corner of exactly one rectangle that a
    shortest path can only leave with ``d_x d_y >= 0`` (its top-left and bottom-right
    corners), -1 for ``d_x d_y <= 0`` (bottom-left, top-right), 0 for no restriction
    (terminals; corners shared by rectangles; every node when a terminal is inside a
    rectangle: a path from inside ignores that rectangle, and the corners it would bend at
    may be hidden in it)."""
    lo, hi, tol, n = scene.lo, scene.hi, scene.tol, scene.n
    corners = np.stack([lo[:n], np.column_stack([hi[:n, 0], lo[:n, 1]]), hi[:n],
                        np.column_stack([lo[:n, 0], hi[:n, 1]])], 1)  # BL, BR, TR, TL
    c, first, count = np.unique(corners.reshape(-1, 2), axis=0, return_index=True, return_counts=True)
    sign = np.where(count == 1, np.array([-1, 1, -1, 1])[first % 4], 0) * (not _inside_any(scene, terminals).any())
    ok = ~np.any(np.all((c[:, None] > lo + tol) & (c[:, None] < hi - tol), axis=-1), axis=1)
    return np.vstack([terminals, c[ok]]), np.r_[np.zeros(len(terminals), int), sign[ok]]


def _tangent(d: np.ndarray, sign: np.ndarray) -> np.ndarray:
    """(P,) bool: direction ``d (P, 2)`` leaves a node of tangent ``sign (P,)`` along or
    outside its rectangle (a path that turns into the rectangle's quadrant there is never
    shortest: its bend could be cut).  See :func:`_nodes`."""
    prod = d[:, 0] * d[:, 1]
    return (sign == 0) | (sign * prod >= 0)


def _touches(scene: _Scene, p0, p1, walls) -> np.ndarray:
    """(P,) bool: closed segment ``p0 -> p1 (P, 2)`` comes within tol of a wall."""
    if len(walls[0]) == 0 or len(p0) == 0:
        return np.zeros(len(p0), dtype=bool)
    d = segment_distance(p0[:, None], p1[:, None], walls[0], walls[1])
    return np.any(d <= scene.tol, axis=1)


def _inside_any(scene: _Scene, points: np.ndarray) -> np.ndarray:
    """(P,) bool: point inside an open rectangle (a terminal in a margin): a segment from
    it ignores that rectangle, so the corner it goes to need not be a tangent one."""
    return np.any(np.all((points[:, None] > scene.lo + scene.tol) & (points[:, None] < scene.hi - scene.tol), axis=-1),
                  axis=1)


def _crosses(a: np.ndarray, b: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """(P, n) bool: the open segment ``a -> b (P, 2)`` meets the open box n.

    Separating axes: the segment's bounding box against the box's (x and y axes), and the
    segment's normal, on which the box spans its centre's value +- its support
    ``|d_y| h_x + |d_x| h_y``.  A segment through a corner or along an edge does not meet it."""
    d = b - a
    c, h = 0.5 * (lo + hi), 0.5 * (hi - lo)
    mn, mx = np.minimum(a, b), np.maximum(a, b)
    hit = (mx[:, None, 0] > lo[:, 0]) & (mn[:, None, 0] < hi[:, 0]) & (mx[:, None, 1] > lo[:, 1])
    hit &= mn[:, None, 1] < hi[:, 1]
    cross = d[:, None, 0] * (c[:, 1] - a[:, None, 1]) - d[:, None, 1] * (c[:, 0] - a[:, None, 0])
    return hit & (np.abs(cross) < np.abs(d[:, None, 1]) * h[:, 0] + np.abs(d[:, None, 0]) * h[:, 1])


def _sees(scene: _Scene, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(P,) bool: the open segment ``a -> b (P, 2)`` misses every open rectangle and
    touches no pinch.  A rectangle containing an end is ignored (only a start or goal
    can be inside one: corners inside are not nodes), so a terminal may leave it.
    Computed in chunks of about a million segment-rectangle pairs."""
    lo, hi = scene.lo + scene.tol, scene.hi - scene.tol
    ok = np.ones(len(a), dtype=bool)
    step = max(1, 2**20 // len(lo))
    for k in range(0, len(a), step):
        sa, sb = a[k:k + step], b[k:k + step]
        hit = _crosses(sa, sb, lo, hi)  # (P, n + 4)
        for end in (sa, sb):
            hit &= ~np.all((end[:, None] > lo) & (end[:, None] < hi), axis=-1)
        ok[k:k + step] = ~hit.any(axis=1)
    ok[ok] = ~_touches(scene, a[ok], b[ok], scene.walls)
    return ok


def _graph(scene: _Scene, terminals: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Nodes ``(N, 2)`` and the visible pairs ``(P, 2)`` with their lengths ``(P,)``, less
    the pairs no shortest path uses (not tangent at a corner, :func:`_tangent`)."""
    nodes, sign = _nodes(scene, terminals)
    i, j = np.triu_indices(len(nodes), 1)
    d = nodes[j] - nodes[i]
    keep = _tangent(d, sign[i]) & _tangent(d, sign[j])
    i, j = i[keep], j[keep]
    ok = _sees(scene, nodes[i], nodes[j])
    pairs = np.column_stack([i[ok], j[ok]])
    return nodes, pairs, np.linalg.norm(nodes[pairs[:, 1]] - nodes[pairs[:, 0]], axis=1)


def _dijkstra(nodes, pairs, length, source: int) -> tuple[np.ndarray, np.ndarray]:
    n = len(nodes)
    adj = csr_matrix((length, (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    return csgraph.dijkstra(adj, directed=False, indices=source, return_predecessors=True)


def _route(scene: _Scene, graph, barriers=()) -> Route | None:
    """The shortest route on ``graph`` (from :func:`_graph`) avoiding the barrier segments."""
    nodes, pairs, length = graph
    if np.array_equal(nodes[0], nodes[1]):
        return Route(nodes[:1].copy(), 0.0, ())
    if barriers:
        walls = (np.array([b[0] for b in barriers]), np.array([b[1] for b in barriers]))
        keep = ~_touches(scene, nodes[pairs[:, 0]], nodes[pairs[:, 1]], walls)
        pairs, length = pairs[keep], length[keep]
    dist, pred = _dijkstra(nodes, pairs, length, 0)
    if not np.isfinite(dist[1]):
        return None
    path, k = [1], 1
    while k != 0:
        k = pred[k]
        path.append(k)
    points = nodes[path[::-1]]
    points = points[np.r_[True, np.any(np.diff(points, axis=0) != 0, axis=1)]]  # a start on a corner
    return Route(points, float(dist[1]), _passes(scene, points))


def _passes(scene: _Scene, points: np.ndarray) -> tuple[Passage, ...]:
    """How the route passes every obstacle, in order along the route."""
    lo, hi = scene.lo[:scene.n], scene.hi[:scene.n]
    if len(lo) == 0 or len(points) < 2:
        return ()
    a, b = points[:-1, None], points[1:, None]  # (S, 1, 2)
    c = 0.5 * (lo + hi)  # (n, 2)
    ab = b - a
    t = np.clip(np.einsum("snk,snk->sn", c - a, ab) / np.einsum("snk,snk->sn", ab, ab), 0.0, 1.0)
    q = a + t[..., None] * ab  # (S, n, 2): each segment's point closest to each centre
    s = np.argmin(np.linalg.norm(q - c, axis=-1), axis=0)  # (n,) the closest segment
    j = np.arange(len(c))
    q, ab = q[s, j], ab[s, 0]
    turn = np.where(_cross(ab, c - q) > 0, 1, -1)
    face = faces_along(q, lo, hi)[j, j]
    touching = segment_box_distance(points[:-1], points[1:], lo, hi).min(axis=0) <= 1e3 * scene.tol
    order = np.lexsort((j, s + t[s, j]))
    return tuple(Passage(int(k), int(face[k]), int(turn[k]), (float(q[k, 0]), float(q[k, 1])), bool(touching[k]))
                 for k in order)


def _barrier(scene: _Scene, passage: Passage) -> tuple[np.ndarray, np.ndarray]:
    """The ray from the obstacle's centre through the route's point nearest to it, up to
    the area boundary: a route touching or crossing it passes the obstacle the same way
    as the route it came from."""
    j = passage.obstacle
    c = 0.5 * (scene.lo[j] + scene.hi[j])
    d = np.array(passage.point) - c
    d /= np.linalg.norm(d)
    bound = np.where(d > 0, scene.area_hi, scene.area_lo)
    with np.errstate(divide="ignore"):
        t = np.where(d != 0, (bound - c) / d, np.inf).min()
    return c, c + max(t, 0.0) * d


# --------------------------------------------------------------------------- interface
def _xy(p) -> np.ndarray:
    return np.asarray(p, dtype=float)[:2]


def shortest_route(start, goal, lo, hi, area_lo, area_hi) -> Route | None:
    """The shortest path from ``start (2,)`` to ``goal (2,)`` in the area outside the open
    rectangles ``lo, hi (n, 2)``; None when no path exists."""
    scene = _scene(lo, hi, area_lo, area_hi)
    return _route(scene, _graph(scene, np.array([_xy(start), _xy(goal)])))


class GoalField:
    """Shortest free-path lengths to one goal from anywhere: one Dijkstra from ``goal
    (2,)`` over the corners, then a start goes straight to the visible node ``v`` that
    minimises ``|s - v| + dist(v, goal)`` (exact: a shortest path's first bend is a node)."""

    def __init__(self, goal, lo, hi, area_lo, area_hi):
        self.scene = _scene(lo, hi, area_lo, area_hi)
        self.nodes, pairs, length = _graph(self.scene, _xy(goal)[None])
        self.sign = _nodes(self.scene, _xy(goal)[None])[1]
        self.dist, _ = _dijkstra(self.nodes, pairs, length, 0)

    def lengths(self, starts: np.ndarray) -> np.ndarray:
        """``(m,)`` lengths from ``starts (m, 2)`` (inf where no path exists).  A start
        inside a rectangle (in a margin) gets a graph of its own (:func:`_nodes`)."""
        starts = np.reshape(np.asarray(starts, dtype=float), (-1, 2))
        m, n = len(starts), len(self.nodes)
        a, b = np.repeat(starts, n, axis=0), np.tile(self.nodes, (m, 1))
        total = np.linalg.norm(b - a, axis=1) + np.tile(self.dist, m)
        try_ = np.isfinite(total) & _tangent(b - a, np.tile(self.sign, m))
        try_[try_] = _sees(self.scene, a[try_], b[try_])
        out = np.where(try_, total, np.inf).reshape(m, n).min(axis=1)
        for k in np.flatnonzero(_inside_any(self.scene, starts)):
            route = _route(self.scene, _graph(self.scene, np.array([starts[k], self.nodes[0]])))
            out[k] = np.inf if route is None else route.length
        return out


def path_lengths(starts, goal, lo, hi, area_lo, area_hi) -> np.ndarray:
    """``(m,)`` shortest free-path lengths from ``starts (m, 2)`` to ``goal (2,)``; see :class:`GoalField`."""
    return GoalField(goal, lo, hi, area_lo, area_hi).lengths(starts)


def distinct_routes(start, goal, lo, hi, area_lo, area_hi, k: int = 3, max_solves: int = 200) -> list[Route]:
    """Up to ``k`` short routes, shortest first, each passing at least one obstacle on
    the other side (``turn``) from every route before it.

    Best-first over sets of barriers (see module docstring): the shortest route under a
    set of barriers is expanded by barring, one at a time, each obstacle on the side the
    route passes it; at most ``max_solves`` shortest-path problems are solved (each a
    Dijkstra on the same visibility graph with the barred edges removed).  The search is a
    heuristic: the k routes are distinct, not proven to be the k shortest classes.
    """
    scene = _scene(lo, hi, area_lo, area_hi)
    graph = _graph(scene, np.array([_xy(start), _xy(goal)]))
    first = _route(scene, graph)
    if first is None:
        return []
    heap, seen_sets, found, signatures, solves = [(first.length, 0, (), first)], {frozenset()}, [], set(), 1
    while heap and len(found) < k:
        _, _, barred, route = heapq.heappop(heap)
        signature = tuple(sorted((p.obstacle, p.turn) for p in route.passes))
        if signature not in signatures:
            signatures.add(signature)
            found.append(route)
        for p in route.passes:
            key = frozenset({*(b[0] for b in barred), (p.obstacle, p.turn)})
            if key in seen_sets or solves >= max_solves:
                continue
            seen_sets.add(key)
            new = (*barred, ((p.obstacle, p.turn), _barrier(scene, p)))
            solves += 1
            r = _route(scene, graph, tuple(b[1] for b in new))
            if r is not None:
                heapq.heappush(heap, (r.length, solves, new, r))
    return found
