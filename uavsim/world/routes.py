"""Shortest collision-free ground routes among inflated obstacle footprints.

A ground target must stay outside the convex polygons of :func:`uavsim.world.ground_footprints`
(the obstacles inflated by ``delta = v_max dt / 2 + clearance``) and inside the area.  The
shortest path in that free space is a polyline that bends only at polygon corners, so
it is found exactly on the **visibility graph**: nodes are the start, the goal and every
polygon corner that lies in the area and outside the other polygons; an edge joins
two nodes when the open segment between them misses every open polygon; Dijkstra on
the edge lengths gives the route.

Conventions (those of :class:`uavsim.world.space.FreeSpace`, so both agree on what connects):

* a route may run along a polygon's edge or round its corner (the polygons are open);
* where two closed polygons touch (at a corner or along an edge, their interiors
  apart) the passage between them has zero width and is closed: a segment through such a
  pinch is not an edge, and a corner lying on one is not a node;
* a start (goal) inside a polygon, e.g. inside a safety margin, may leave (enter) it
  straight: for edges at that node the polygons containing it are ignored.

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

Shapes: polygons as :class:`uavsim.world.Polygons` (``n`` of them), points ``(2,)``,
routes ``(m, 2)``.
"""

from __future__ import annotations

import heapq
from dataclasses import dataclass

import numpy as np
from scipy.sparse import csgraph, csr_matrix

from .model import Polygons

REL_TOL = 1e-9
CHUNK = 2**20  # segment-polygon-face triples tested at once


@dataclass(frozen=True)
class Passage:
    """How a route passes one obstacle.

    Attributes
    ----------
    obstacle : index into the polygons.
    face : the face (edge index of the polygon) the route is outside of where it comes
        closest to the obstacle's centre (at a corner, the one it is farther beyond).
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
        """Obstacle index -> the face it is passed on, for every obstacle."""
        return {p.obstacle: p.face for p in self.passes}


# --------------------------------------------------------------------------- segment tests
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


def segment_polygon_distance(p0, p1, polys: Polygons) -> np.ndarray:
    """(..., n) distance between the closed segment ``p0 -> p1 (..., 2)`` and closed
    convex polygon n.  Zero when they meet; otherwise the nearest pair involves a segment
    end or a polygon corner."""
    p0, p1 = np.asarray(p0, dtype=float), np.asarray(p1, dtype=float)
    v, w = polys.vertices, np.roll(polys.vertices, -1, axis=1)  # (n, F, 2) edges v -> w
    ends = [_point_segment_distance(q[..., None, None, :], v, w).min(axis=-1) for q in (p0, p1)]
    ends = [np.where(polys.contains(q), 0.0, e) for q, e in zip((p0, p1), ends)]
    corners = _point_segment_distance(v, p0[..., None, None, :], p1[..., None, None, :]).min(axis=-1)
    dist = np.minimum(np.minimum(*ends), corners)
    return np.where(_meets(p0, p1, polys), 0.0, dist)


def _meets(p0, p1, polys: Polygons) -> np.ndarray:
    """(..., n) bool: the closed segment ``p0 -> p1 (..., 2)`` meets closed polygon n, by
    separating axes: the polygon's edge normals and the segment's normal."""
    d = p1 - p0
    seg_a = np.einsum("...d,nfd->...nf", p0, polys.normals)
    seg_b = np.einsum("...d,nfd->...nf", p1, polys.normals)
    low = np.einsum("nfd,ngd->nfg", polys.normals, polys.vertices).min(axis=-1)  # (n, F)
    apart = (np.minimum(seg_a, seg_b) > polys.offsets) | (np.maximum(seg_a, seg_b) < low)
    normal = np.stack([d[..., 1], -d[..., 0]], axis=-1)
    c = np.einsum("...d,...d->...", normal, p0)[..., None]
    proj = np.einsum("...d,nfd->...nf", normal, polys.vertices)
    along = (c > proj.max(axis=-1)) | (c < proj.min(axis=-1))
    return ~(apart.any(axis=-1) | along)


def faces_along(points: np.ndarray, polys: Polygons) -> np.ndarray:
    """(..., n) int: per point and polygon, the real face with the largest outward
    clearance, the natural face to fix for that point in Eq. (8d)."""
    slack = np.where(polys.valid, polys.slack(points), -np.inf)
    return np.argmax(slack, axis=-1)


# --------------------------------------------------------------------------- the graph
def pinches(polys: Polygons, tol: float = 0.0, skip_last: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Where two closed convex polygons touch with their interiors apart (within ``tol``):
    each pinch is a point or a segment, returned as segments ``(a (k, 2), b (k, 2))``.
    Pairs among the last ``skip_last`` polygons are left out.

    Two convex polygons touch when the largest gap between their projections on the
    edge normals of both is zero (within tol); the contact is where their extreme
    features on that axis overlap along the perpendicular."""
    n = len(polys)
    i, j = np.triu_indices(n, 1)
    keep = (i < n - skip_last) & np.all(polys.lo[i] <= polys.hi[j] + tol, axis=1) & np.all(
        polys.lo[j] <= polys.hi[i] + tol, axis=1)
    i, j = i[keep], j[keep]
    if not len(i):
        return np.zeros((0, 2)), np.zeros((0, 2))
    axes = np.concatenate([polys.normals[i], polys.normals[j]], axis=1)  # (P, 2F, 2)
    pa = np.einsum("pad,pfd->paf", axes, polys.vertices[i])
    pb = np.einsum("pad,pfd->paf", axes, polys.vertices[j])
    gap_ab = pb.min(-1) - pa.max(-1)  # b beyond a along the axis
    gap_ba = pa.min(-1) - pb.max(-1)
    gap = np.maximum(gap_ab, gap_ba)
    k = np.argmax(gap, axis=1)
    rows = np.arange(len(i))
    best = gap[rows, k]
    touch = np.abs(best) <= tol
    a_first = gap_ab[rows, k] >= gap_ba[rows, k]  # polygon i on the low side
    axis = axes[rows, k]
    perp = np.stack([-axis[:, 1], axis[:, 0]], axis=1)
    low = np.where(a_first[:, None, None], polys.vertices[i], polys.vertices[j])
    high = np.where(a_first[:, None, None], polys.vertices[j], polys.vertices[i])
    level_lo = np.einsum("pd,pfd->pf", axis, low)
    level_hi = np.einsum("pd,pfd->pf", axis, high)
    t_lo = np.einsum("pd,pfd->pf", perp, low)
    t_hi = np.einsum("pd,pfd->pf", perp, high)
    on_lo = level_lo >= level_lo.max(1, keepdims=True) - tol  # the low polygon's feature facing the other
    on_hi = level_hi <= level_hi.min(1, keepdims=True) + tol
    t0 = np.maximum(np.where(on_lo, t_lo, np.inf).min(1), np.where(on_hi, t_hi, np.inf).min(1))
    t1 = np.minimum(np.where(on_lo, t_lo, -np.inf).max(1), np.where(on_hi, t_hi, -np.inf).max(1))
    touch &= t0 <= t1 + tol
    c = level_lo.max(1)
    a = c[:, None] * axis + t0[:, None] * perp
    b = c[:, None] * axis + np.maximum(t0, t1)[:, None] * perp
    return a[touch], b[touch]


@dataclass(frozen=True, eq=False)
class _Scene:
    """The polygons, then four open rectangles framing the area (its outside)."""

    polys: Polygons  # n + 4
    n: int  # real polygons (the first n)
    area_lo: np.ndarray
    area_hi: np.ndarray
    tol: float
    walls: tuple[np.ndarray, np.ndarray]  # closed segments nothing may touch: pinches (+ barriers)


def _scene(polys: Polygons, area_lo, area_hi) -> _Scene:
    a, b = np.asarray(area_lo, dtype=float)[:2], np.asarray(area_hi, dtype=float)[:2]
    size = float(np.max(b - a))
    tol, big = REL_TOL * size, 2.0 * size + np.abs(np.r_[a, b]).max()
    # left, right (full height), bottom, top (area width): a polygon touching the area's
    # boundary closes the passage there, like two touching polygons
    frame_lo = np.array([[a[0] - big, a[1] - big], [b[0], a[1] - big], [a[0], a[1] - big], [a[0], b[1]]])
    frame_hi = np.array([[a[0], b[1] + big], [b[0] + big, b[1] + big], [b[0], a[1]], [b[0], b[1] + big]])
    everything = Polygons.concat(polys, Polygons.boxes(frame_lo, frame_hi)) if len(polys) else \
        Polygons.boxes(frame_lo, frame_hi)
    return _Scene(everything, len(polys), a, b, tol, pinches(everything, tol, skip_last=4))


def _corners(scene: _Scene) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The usable polygon corners ``(C, 2)`` (outside every open polygon of the scene,
    the frame round the area included), each one's two neighbouring corners as vectors
    ``(C, 2, 2)``, and whether it is the corner of exactly one polygon ``(C,)``: see
    :meth:`Visibility.nodes`."""
    polys, tol, n = scene.polys, scene.tol, scene.n
    real = polys.take(np.arange(n))
    v = real.vertices
    prev, nxt = np.roll(v, 1, axis=1), np.roll(v, -1, axis=1)
    k = real.sides[:, None]
    f = np.arange(real.width)[None, :]
    prev = np.where((f == 0)[..., None], v[np.arange(n)[:, None], k - 1], prev)  # wrap over the real corners
    nxt = np.where((f == k - 1)[..., None], v[:, :1], nxt)
    ok = real.valid.reshape(-1)
    corners, nb = v.reshape(-1, 2)[ok], np.stack([prev, nxt], axis=2).reshape(-1, 2, 2)[ok]
    c, first, count = np.unique(corners, axis=0, return_index=True, return_counts=True)
    vectors = nb[first] - c[:, None, :]
    free = ~polys.contains(c, tol=-tol).any(axis=1)
    return c[free], vectors[free], count[free] == 1


def _tangent(d: np.ndarray, vectors: np.ndarray, restricted: np.ndarray) -> np.ndarray:
    """(P,) bool: direction ``d (P, 2)`` leaves a node along a line that has both its
    neighbouring corners ``vectors (P, 2, 2)`` on one side (a path that turns into the
    polygon there is never shortest: its bend could be cut).  See :meth:`Visibility.nodes`."""
    side = _cross(d[:, None, :], vectors)
    return ~restricted | (side[:, 0] * side[:, 1] >= 0)


def _touches(scene: _Scene, p0, p1, walls) -> np.ndarray:
    """(P,) bool: closed segment ``p0 -> p1 (P, 2)`` comes within tol of a wall."""
    if len(walls[0]) == 0 or len(p0) == 0:
        return np.zeros(len(p0), dtype=bool)
    d = segment_distance(p0[:, None], p1[:, None], walls[0], walls[1])
    return np.any(d <= scene.tol, axis=1)


def _inside_any(scene: _Scene, points: np.ndarray) -> np.ndarray:
    """(P,) bool: point inside an open polygon (a terminal in a margin): a segment from
    it ignores that polygon, so the corner it goes to need not be a tangent one."""
    return scene.polys.contains(points, tol=-scene.tol).any(axis=-1)


def _sees(scene: _Scene, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(P,) bool: the open segment ``a -> b (P, 2)`` misses every open polygon and
    touches no pinch.  A polygon containing an end is ignored (only a start or goal can
    be inside one: corners inside are not nodes), so a terminal may leave it.  Only the
    polygons whose bounding box meets the segment's are tested, in chunks."""
    polys, tol = scene.polys, scene.tol
    ok = np.ones(len(a), dtype=bool)
    lo, hi = polys.lo + tol, polys.hi - tol
    step = max(1, CHUNK // (len(polys) * polys.width))
    for k in range(0, len(a), step):
        sa, sb = a[k:k + step], b[k:k + step]
        mn, mx = np.minimum(sa, sb), np.maximum(sa, sb)
        near = np.all((mx[:, None] > lo) & (mn[:, None] < hi), axis=-1)  # (P, n)
        p, j = np.nonzero(near)
        hit = _meets_pairs(sa[p], sb[p], polys, j, tol)
        hit &= ~polys.take(j).contains_pairwise(sa[p], -tol) & ~polys.take(j).contains_pairwise(sb[p], -tol)
        bad = np.zeros(len(sa), dtype=bool)
        bad[p[hit]] = True
        ok[k:k + step] = ~bad
    ok[ok] = ~_touches(scene, a[ok], b[ok], scene.walls)
    return ok


def _meets_pairs(p0, p1, polys: Polygons, j: np.ndarray, tol: float) -> np.ndarray:
    """(P,) bool: open segment P meets open polygon ``j[P]`` shrunk by tol (:func:`_meets`)."""
    if not len(j):
        return np.zeros(0, dtype=bool)
    normals, offsets, vertices = polys.normals[j], polys.offsets[j], polys.vertices[j]  # (P, F, ...)
    seg_a = np.einsum("pd,pfd->pf", p0, normals)
    seg_b = np.einsum("pd,pfd->pf", p1, normals)
    low = np.einsum("pfd,pgd->pfg", normals, vertices).min(axis=-1)
    apart = (np.minimum(seg_a, seg_b) >= offsets - tol) | (np.maximum(seg_a, seg_b) <= low + tol)
    d = p1 - p0
    normal = np.stack([d[:, 1], -d[:, 0]], axis=1)
    scale = np.linalg.norm(normal, axis=1)
    c = np.einsum("pd,pd->p", normal, p0)
    proj = np.einsum("pd,pfd->pf", normal, vertices)
    along = (c >= proj.max(axis=1) - tol * scale) | (c <= proj.min(axis=1) + tol * scale)
    return ~(apart.any(axis=1) | along)


class Visibility:
    """The visibility graph of one scene (polygons in an area), its corner-to-corner
    edges found once and kept: a start and a goal join it per query (:meth:`graph`), at
    the cost of their own edges only.  Build one per world where routes are asked for
    again and again (guidance asks at every first plan: on a 400-building town the
    corner edges took 2.8 s of a 3.8 s route search)."""

    def __init__(self, polys: Polygons, area_lo, area_hi):
        self.scene = _scene(polys, area_lo, area_hi)
        self.corners, self.vectors, self.single = _corners(self.scene)
        self._edges: dict[bool, np.ndarray] = {}  # tangent rule on? -> visible corner pairs (P, 2)

    def _corner_edges(self, restricted: np.ndarray) -> np.ndarray:
        key = bool(restricted.any())
        if key not in self._edges:
            self._edges[key] = self._visible(self.corners, self.vectors, restricted,
                                             *np.triu_indices(len(self.corners), 1))
        return self._edges[key]

    def _visible(self, nodes, vectors, restricted, i, j) -> np.ndarray:
        """The pairs ``(P, 2)`` among ``(i, j)`` a shortest path may use: tangent at both
        ends (:func:`_tangent`) and in sight of each other (:func:`_sees`)."""
        d = nodes[j] - nodes[i]
        keep = _tangent(d, vectors[i], restricted[i]) & _tangent(d, vectors[j], restricted[j])
        i, j = i[keep], j[keep]
        ok = _sees(self.scene, nodes[i], nodes[j])
        return np.column_stack([i[ok], j[ok]])

    def nodes(self, terminals: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Nodes ``(N, 2)``: the terminals (start, goal), then the usable polygon corners; each
        node's two neighbouring corners as vectors ``(N, 2, 2)`` and whether a shortest path
        there must be tangent ``(N,)``: a corner of exactly one polygon, which a shortest path
        only leaves along a line with both neighbours on one side (:func:`_tangent`).  No
        restriction at terminals, at corners shared by polygons, and at any node when a
        terminal is inside a polygon (a path from inside ignores that polygon, and the
        corners it would bend at may be hidden in it)."""
        restricted = self.single & (not _inside_any(self.scene, terminals).any())
        t = len(terminals)
        vectors = np.concatenate([np.zeros((t, 2, 2)), self.vectors])
        return np.vstack([terminals, self.corners]), vectors, np.r_[np.zeros(t, bool), restricted]

    def graph(self, terminals: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Nodes ``(N, 2)`` (:meth:`nodes`: the ``terminals (t, 2)`` first) and the
        visible pairs ``(P, 2)`` (``i < j``, in row order) with their lengths ``(P,)``,
        less the pairs no shortest path uses (not tangent at a corner, :func:`_tangent`)."""
        t = len(terminals)
        nodes, vectors, restricted = self.nodes(terminals)
        n = len(nodes)  # the pairs (i, j > i) with a terminal i; the corner pairs are kept
        i = np.concatenate([np.full(n - 1 - a, a) for a in range(t)]).astype(int)
        j = np.concatenate([np.arange(a + 1, n) for a in range(t)]).astype(int)
        pairs = np.vstack([self._visible(nodes, vectors, restricted, i, j), self._corner_edges(restricted[t:]) + t])
        return nodes, pairs, np.linalg.norm(nodes[pairs[:, 1]] - nodes[pairs[:, 0]], axis=1)

    def shortest_route(self, start, goal) -> Route | None:
        """The shortest path from ``start (2,)`` to ``goal (2,)`` outside the open
        polygons; None when no path exists."""
        return _route(self.scene, self.graph(np.array([_xy(start), _xy(goal)])))

    def distinct_routes(self, start, goal, k: int = 3, max_solves: int = 200) -> list[Route]:
        """See :func:`distinct_routes`."""
        scene = self.scene
        graph = self.graph(np.array([_xy(start), _xy(goal)]))
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


def _dijkstra(nodes, pairs, length, source: int) -> tuple[np.ndarray, np.ndarray]:
    n = len(nodes)
    adj = csr_matrix((length, (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    return csgraph.dijkstra(adj, directed=False, indices=source, return_predecessors=True)


def _route(scene: _Scene, graph, barriers=()) -> Route | None:
    """The shortest route on ``graph`` (from :meth:`Visibility.graph`) avoiding the barrier segments."""
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
    polys = scene.polys.take(np.arange(scene.n))
    if len(polys) == 0 or len(points) < 2:
        return ()
    a, b = points[:-1, None], points[1:, None]  # (S, 1, 2)
    c = polys.centres  # (n, 2)
    ab = b - a
    t = np.clip(np.einsum("snk,snk->sn", c - a, ab) / np.einsum("snk,snk->sn", ab, ab), 0.0, 1.0)
    q = a + t[..., None] * ab  # (S, n, 2): each segment's point closest to each centre
    s = np.argmin(np.linalg.norm(q - c, axis=-1), axis=0)  # (n,) the closest segment
    j = np.arange(len(c))
    q, ab = q[s, j], ab[s, 0]
    turn = np.where(_cross(ab, c - q) > 0, 1, -1)
    face = faces_along(q, polys)[j, j]
    touching = segment_polygon_distance(points[:-1], points[1:], polys).min(axis=0) <= 1e3 * scene.tol
    order = np.lexsort((j, s + t[s, j]))
    return tuple(Passage(int(k), int(face[k]), int(turn[k]), (float(q[k, 0]), float(q[k, 1])), bool(touching[k]))
                 for k in order)


def _barrier(scene: _Scene, passage: Passage) -> tuple[np.ndarray, np.ndarray]:
    """The ray from the obstacle's centre through the route's point nearest to it, up to
    the area boundary: a route touching or crossing it passes the obstacle the same way
    as the route it came from.  A route through the centre (a start or goal inside the
    obstacle, at its centre) has no such ray: any one bars it, +x is taken."""
    c = scene.polys.centres[passage.obstacle]
    d = np.array(passage.point) - c
    norm = np.linalg.norm(d)
    d = d / norm if norm > scene.tol else np.array([1.0, 0.0])
    bound = np.where(d > 0, scene.area_hi, scene.area_lo)
    with np.errstate(divide="ignore"):
        t = np.where(d != 0, (bound - c) / d, np.inf).min()
    return c, c + max(t, 0.0) * d


# --------------------------------------------------------------------------- interface
def _xy(p) -> np.ndarray:
    return np.asarray(p, dtype=float)[:2]


def shortest_route(start, goal, polys: Polygons, area_lo, area_hi) -> Route | None:
    """The shortest path from ``start (2,)`` to ``goal (2,)`` in the area outside the open
    polygons; None when no path exists."""
    return Visibility(polys, area_lo, area_hi).shortest_route(start, goal)


class GoalField:
    """Shortest free-path lengths to one goal from anywhere: one Dijkstra from ``goal
    (2,)`` over the corners, then a start goes straight to the visible node ``v`` that
    minimises ``|s - v| + dist(v, goal)`` (exact: a shortest path's first bend is a node)."""

    def __init__(self, goal, polys: Polygons, area_lo, area_hi):
        self.visibility = Visibility(polys, area_lo, area_hi)
        self.scene = self.visibility.scene
        self.nodes, pairs, length = self.visibility.graph(_xy(goal)[None])
        _, self.vectors, self.restricted = self.visibility.nodes(_xy(goal)[None])
        self.dist, _ = _dijkstra(self.nodes, pairs, length, 0)

    def lengths(self, starts: np.ndarray) -> np.ndarray:
        """``(m,)`` lengths from ``starts (m, 2)`` (inf where no path exists).  A start
        inside a polygon (in a margin) gets a graph of its own (:meth:`Visibility.nodes`)."""
        starts = np.reshape(np.asarray(starts, dtype=float), (-1, 2))
        m, n = len(starts), len(self.nodes)
        a, b = np.repeat(starts, n, axis=0), np.tile(self.nodes, (m, 1))
        total = np.linalg.norm(b - a, axis=1) + np.tile(self.dist, m)
        try_ = np.isfinite(total) & _tangent(b - a, np.tile(self.vectors, (m, 1, 1)), np.tile(self.restricted, m))
        try_[try_] = _sees(self.scene, a[try_], b[try_])
        out = np.where(try_, total, np.inf).reshape(m, n).min(axis=1)
        for k in np.flatnonzero(_inside_any(self.scene, starts)):
            route = self.visibility.shortest_route(starts[k], self.nodes[0])
            out[k] = np.inf if route is None else route.length
        return out


def path_lengths(starts, goal, polys: Polygons, area_lo, area_hi) -> np.ndarray:
    """``(m,)`` shortest free-path lengths from ``starts (m, 2)`` to ``goal (2,)``; see :class:`GoalField`."""
    return GoalField(goal, polys, area_lo, area_hi).lengths(starts)


def distinct_routes(start, goal, polys: Polygons, area_lo, area_hi, k: int = 3, max_solves: int = 200) -> list[Route]:
    """Up to ``k`` short routes, shortest first, each passing at least one obstacle on
    the other side (``turn``) from every route before it.

    Best-first over sets of barriers (see module docstring): the shortest route under a
    set of barriers is expanded by barring, one at a time, each obstacle on the side the
    route passes it; at most ``max_solves`` shortest-path problems are solved (each a
    Dijkstra on the same visibility graph with the barred edges removed).  The search is a
    heuristic: the k routes are distinct, not proven to be the k shortest classes.
    """
    return Visibility(polys, area_lo, area_hi).distinct_routes(start, goal, k, max_solves)
