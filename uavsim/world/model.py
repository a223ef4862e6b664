"""Surveillance area, obstacles, goal regions and the UAV operating region.

Model ([Papaioannou2023] Sec. III-D): obstacle n is a convex polytope given by
half-spaces with outward unit normals ``a_i^n`` and offsets ``b_i^n``; a point p is
inside it when ``a_i^n . p <= b_i^n`` for all its faces, and a collision is avoided when
Eq. (5) holds, ``exists i: a_i^n . p > b_i^n``.  The paper's obstacles are cuboids (six
faces); here an obstacle is a vertical prism over a convex footprint (its sides and two
caps), of which a cuboid is the case with a rectangular footprint.  Obstacles are closed
sets: a point on a face is inside (touching is a collision).

Shapes: footprints as :class:`Polygons` (padded ``(n_obs, F, 2)`` vertices), 3-D
``normals (n_obs, F + 2, 3)``, ``offsets (n_obs, F + 2)``, points ``(..., 3)``.  All
tests broadcast over leading axes; none loops in Python over points.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..declare import Spec

# Outward normals of an axis-aligned cuboid, in the order +x, -x, +y, -y, +z, -z.
CUBOID_NORMALS = np.array(
    [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], dtype=float
)


def fmt(v) -> str:
    """A vector for messages: ``[150, 200]``."""
    return "[" + ", ".join(f"{x:g}" for x in np.asarray(v).ravel()) + "]"


def cuboid_halfspaces(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Half-space form of axis-aligned cuboids.

    Parameters
    ----------
    lo, hi : (n, 3) corner coordinates, ``lo < hi``.

    Returns
    -------
    normals : (n, 6, 3) outward unit normals ``a_i`` (order +x, -x, +y, -y, +z, -z).
    offsets : (n, 6) offsets ``b_i = a_i . (point on face i)``.

    References
    ----------
    [Papaioannou2023] Sec. III-D, the six inequalities before Eq. (5).
    """
    lo, hi = np.atleast_2d(lo).astype(float), np.atleast_2d(hi).astype(float)
    normals = np.broadcast_to(CUBOID_NORMALS, (lo.shape[0], 6, 3)).copy()
    offsets = np.stack([hi[:, 0], -lo[:, 0], hi[:, 1], -lo[:, 1], hi[:, 2], -lo[:, 2]], axis=1)
    return normals, offsets


def inside_polytopes(points: np.ndarray, normals: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Which polytope (closed) contains each point.

    Parameters
    ----------
    points : (..., d)
    normals : (n, f, d), offsets : (n, f)

    Returns
    -------
    (..., n) bool: ``all_i a_i . p <= b_i`` (the negation of Eq. (5)).
    """
    lhs = np.einsum("...d,nfd->...nf", points, normals)
    return np.all(lhs <= offsets, axis=-1)


def segments_hit_polytopes(
    p0: np.ndarray, p1: np.ndarray, normals: np.ndarray, offsets: np.ndarray
) -> np.ndarray:
    """Which closed polytope each straight segment ``p0 -> p1`` touches or crosses.

    Clips the segment parameter ``s in [0, 1]`` against every face (Cyrus-Beck):
    ``a . (p0 + s d) <= b``.  A face with ``a . d > 0`` bounds s from above,
    ``a . d < 0`` from below, ``a . d = 0`` keeps all s or none.  The segment meets
    the polytope when the clipped interval is non-empty.

    Parameters
    ----------
    p0, p1 : (..., d) segment ends (broadcast together).
    normals : (n, f, d), offsets : (n, f)

    Returns
    -------
    (..., n) bool.
    """
    d = p1 - p0
    slack = offsets - np.einsum("...d,nfd->...nf", p0, normals)  # b - a.p0
    rate = np.einsum("...d,nfd->...nf", d, normals)  # a.d
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = slack / rate
    s_hi = np.min(np.where(rate > 0, ratio, np.inf), axis=-1, initial=1.0)
    s_lo = np.max(np.where(rate < 0, ratio, -np.inf), axis=-1, initial=0.0)
    parallel_ok = np.all((rate != 0) | (slack >= 0), axis=-1)
    return parallel_ok & (s_lo <= s_hi)


@dataclass(frozen=True, eq=False)
class GoalRegion:
    """A ground rectangle ``[lo, hi]`` (x, y) with centroid ``G_o`` at z = 0.

    References
    ----------
    [Papaioannou2023] Sec. III-A and Eq. (7) (centroid ``G_o^j``).
    """

    name: str
    lo: np.ndarray  # (2,)
    hi: np.ndarray  # (2,)

    @property
    def centroid(self) -> np.ndarray:
        """(3,) centre of the rectangle on the ground."""
        return np.array([*(0.5 * (self.lo + self.hi)), 0.0])


@dataclass(frozen=True, eq=False)
class Region2D:
    """A convex polygon in the ground plane (x, y) as half-spaces ``normals . p <= offsets``.

    Used for the UAV operating region, the paper's "allowed sub-region" (Sec. VI-B).
    ``vertices`` (k, 2) are kept counter-clockwise for drawing and manoeuvre design.
    """

    vertices: np.ndarray  # (k, 2), counter-clockwise
    normals: np.ndarray  # (k, 2)
    offsets: np.ndarray  # (k,)

    @classmethod
    def from_vertices(cls, vertices: np.ndarray) -> "Region2D":
        """Half-spaces of a convex counter-clockwise polygon (validated by the caller)."""
        v = np.asarray(vertices, dtype=float)
        edge = np.roll(v, -1, axis=0) - v
        n = np.stack([edge[:, 1], -edge[:, 0]], axis=1)
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        return cls(vertices=v, normals=n, offsets=np.einsum("kd,kd->k", n, v))

    @classmethod
    def box(cls, lo: np.ndarray, hi: np.ndarray) -> "Region2D":
        """Axis-aligned rectangle ``[lo, hi]``."""
        (x0, y0), (x1, y1) = lo, hi
        return cls.from_vertices(np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]]))

    def contains(self, points: np.ndarray) -> np.ndarray:
        """(...,) bool: point (x, y, ...) lies in the closed polygon."""
        xy = np.asarray(points)[..., :2]
        return np.all(xy @ self.normals.T <= self.offsets + 1e-9, axis=-1)


@dataclass(frozen=True, eq=False)
class Polygons:
    """Convex polygons in the ground plane as padded arrays (n polygons, at most F sides).

    Edge i of polygon j runs from ``vertices[j, i]`` to ``vertices[j, (i + 1) % F]``;
    the real vertices come first, counter-clockwise, and the padding repeats vertex 0, so
    the real edges are ``i < sides[j]`` (the last one closes the polygon) and the padded
    ones have zero length.  A padded edge copies edge 0's half-space, so tests over all
    edges (``all_i a_i . p <= b_i``) are unchanged by the padding; ``valid`` marks the
    real ones.

    Attributes
    ----------
    vertices : (n, F, 2); sides : (n,) real vertex counts (>= 3).
    normals : (n, F, 2) outward unit normals ``a_i``; offsets : (n, F) ``b_i``: the
    closed polygon is ``{p : a_i . p <= b_i for every i}``; valid : (n, F) bool.
    """

    vertices: np.ndarray
    sides: np.ndarray
    normals: np.ndarray
    offsets: np.ndarray
    valid: np.ndarray

    @classmethod
    def from_vertices(cls, vertices: np.ndarray, sides: np.ndarray) -> "Polygons":
        """From padded counter-clockwise vertices ``(n, F, 2)`` (see the class docstring);
        the caller has checked convexity and orientation (:func:`convex_ccw`)."""
        v = np.asarray(vertices, dtype=float)
        sides = np.asarray(sides, dtype=int).reshape(-1)
        f = v.shape[1]
        valid = np.arange(f)[None, :] < sides[:, None]
        v = np.where(valid[..., None], v, v[:, :1])  # the padding repeats vertex 0
        edge = np.roll(v, -1, axis=1) - v
        length = np.linalg.norm(edge, axis=-1, keepdims=True)
        normals = np.stack([edge[..., 1], -edge[..., 0]], axis=-1) / np.where(length > 0, length, 1.0)
        normals = np.where(valid[..., None], normals, normals[:, :1])
        offsets = np.einsum("nfd,nfd->nf", normals, v)
        offsets = np.where(valid, offsets, offsets[:, :1])
        return cls(v, sides, normals, offsets, valid)

    @classmethod
    def from_list(cls, polygons) -> "Polygons":
        """From a sequence of ``(k_j, 2)`` counter-clockwise convex vertex arrays."""
        polygons = [np.asarray(p, dtype=float).reshape(-1, 2) for p in polygons]
        f = max([len(p) for p in polygons], default=4)
        v = np.zeros((len(polygons), f, 2))
        for j, p in enumerate(polygons):  # once per world, over obstacles
            v[j, : len(p)] = p
        return cls.from_vertices(v, np.array([len(p) for p in polygons], dtype=int))

    @classmethod
    def boxes(cls, lo: np.ndarray, hi: np.ndarray) -> "Polygons":
        """Axis-aligned rectangles ``[lo, hi]`` ``(n, 2)``; their faces in the order
        -y, +x, +y, -x (counter-clockwise from the bottom edge)."""
        lo, hi = np.reshape(lo, (-1, 2)).astype(float), np.reshape(hi, (-1, 2)).astype(float)
        v = np.stack([lo, np.column_stack([hi[:, 0], lo[:, 1]]), hi, np.column_stack([lo[:, 0], hi[:, 1]])], axis=1)
        return cls.from_vertices(v, np.full(len(lo), 4))

    @classmethod
    def concat(cls, *parts: "Polygons") -> "Polygons":
        """The polygons of ``parts`` in order, padded to the widest."""
        f = max(p.width for p in parts)

        def pad(a, fill):
            extra = f - a.shape[1]
            return a if not extra else np.concatenate([a, np.repeat(fill, extra, axis=1)], axis=1)

        return cls(np.concatenate([pad(p.vertices, p.vertices[:, :1]) for p in parts]),
                   np.concatenate([p.sides for p in parts]),
                   np.concatenate([pad(p.normals, p.normals[:, :1]) for p in parts]),
                   np.concatenate([pad(p.offsets, p.offsets[:, :1]) for p in parts]),
                   np.concatenate([pad(p.valid, np.zeros_like(p.valid[:, :1])) for p in parts]))

    def __len__(self) -> int:
        return len(self.sides)

    @property
    def width(self) -> int:
        """F, the padded number of sides."""
        return self.vertices.shape[1]

    def take(self, idx) -> "Polygons":
        """The polygons ``idx``."""
        return Polygons(self.vertices[idx], self.sides[idx], self.normals[idx], self.offsets[idx], self.valid[idx])

    @property
    def lo(self) -> np.ndarray:
        """(n, 2) bounding boxes' lower corners."""
        return self.vertices.min(axis=1)

    @property
    def hi(self) -> np.ndarray:
        return self.vertices.max(axis=1)

    @property
    def centres(self) -> np.ndarray:
        """(n, 2) means of the real vertices."""
        return np.einsum("nfd,nf->nd", self.vertices, self.valid) / self.sides[:, None]

    @property
    def area(self) -> np.ndarray:
        """(n,) areas (shoelace over the real edges; padded edges have zero length)."""
        v, w = self.vertices, np.roll(self.vertices, -1, axis=1)
        return 0.5 * (v[..., 0] * w[..., 1] - v[..., 1] * w[..., 0]).sum(axis=1)

    def neighbours(self) -> np.ndarray:
        """(n, F, 2) the two edges meeting edge i (the previous and the next, cyclically
        over the real edges; padded edges point at themselves)."""
        i = np.arange(self.width)[None, :]
        k = self.sides[:, None]
        return np.where(self.valid[..., None], np.stack([(i - 1) % k, (i + 1) % k], axis=-1), i[..., None])

    def inflated(self, margin: float) -> "Polygons":
        """Every edge pushed out by ``margin`` along its normal (a mitred offset): vertex i,
        where edges i - 1 and i meet, moves by ``margin (a_{i-1} + a_i) / (1 + a_{i-1} . a_i)``."""
        prev = self.normals[np.arange(len(self))[:, None], self.neighbours()[..., 0]]
        a = self.normals
        shift = margin * (prev + a) / (1.0 + np.einsum("nfd,nfd->nf", prev, a))[..., None]
        v = np.where(self.valid[..., None], self.vertices + shift, 0.0)
        v = np.where(self.valid[..., None], v, v[:, :1])
        return Polygons(v, self.sides, self.normals, self.offsets + margin, self.valid)

    def contains(self, points: np.ndarray, tol: float = 0.0) -> np.ndarray:
        """``(..., n)`` bool: point in the closed polygon grown by ``tol`` (``< 0``: the
        open polygon shrunk by ``-tol``, strictly)."""
        lhs = np.einsum("...d,nfd->...nf", np.asarray(points, dtype=float)[..., :2], self.normals)
        if tol >= 0:
            return np.all(lhs <= self.offsets + tol, axis=-1)
        return np.all(lhs < self.offsets + tol, axis=-1)

    def contains_pairwise(self, points: np.ndarray, tol: float = 0.0) -> np.ndarray:
        """``(n,)`` bool: point k ``(n, 2)`` in polygon k (as :meth:`contains`)."""
        lhs = np.einsum("nd,nfd->nf", np.asarray(points, dtype=float)[:, :2], self.normals)
        if tol >= 0:
            return np.all(lhs <= self.offsets + tol, axis=-1)
        return np.all(lhs < self.offsets + tol, axis=-1)

    def slack(self, points: np.ndarray) -> np.ndarray:
        """``(..., n, F)`` signed clearance ``a_i . p - b_i`` of points ``(..., 2)`` (>= 0:
        beyond edge i); padded edges repeat edge 0."""
        return np.einsum("...d,nfd->...nf", np.asarray(points, dtype=float)[..., :2], self.normals) - self.offsets


def convex_ccw(vertices: np.ndarray) -> str:
    """Why ``(k, 2)`` vertices are not a strictly convex counter-clockwise polygon
    (fewer than 3, repeated, clockwise, a reflex or straight corner), "" when they are."""
    v = np.asarray(vertices, dtype=float)
    if v.ndim != 2 or v.shape[1] != 2 or len(v) < 3:
        return "needs at least 3 [x, y] vertices"
    edge = np.roll(v, -1, axis=0) - v
    if np.any(np.linalg.norm(edge, axis=1) == 0):
        return "repeats a vertex"
    turn = edge[:, 0] * np.roll(edge, -1, axis=0)[:, 1] - edge[:, 1] * np.roll(edge, -1, axis=0)[:, 0]
    scale = np.linalg.norm(edge, axis=1) * np.roll(np.linalg.norm(edge, axis=1), -1)
    if np.all(turn < 0):
        return "is clockwise; list the vertices counter-clockwise"
    if np.any(turn <= 1e-12 * scale):
        k = int(np.argmin(turn / scale))
        return f"is not strictly convex at vertex {(k + 1) % len(v)} {fmt(v[(k + 1) % len(v)])}"
    if abs(np.arctan2(turn, np.einsum("kd,kd->k", edge, np.roll(edge, -1, axis=0))).sum() - 2 * np.pi) > 1e-6:
        return "winds round more than once"
    return ""


def prism_halfspaces(footprints: Polygons, z_lo: np.ndarray, z_hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Half-space form of vertical prisms: ``(n, F + 2, 3)`` outward unit normals (the
    footprint's sides, then +z and -z) and ``(n, F + 2)`` offsets.  A cuboid's footprint
    from :meth:`Polygons.boxes` gives its six faces.

    References
    ----------
    [Papaioannou2023] Sec. III-D: an obstacle is the intersection of half-spaces ``a_i . p <= b_i``.
    """
    n = len(footprints)
    side = np.concatenate([footprints.normals, np.zeros((n, footprints.width, 1))], axis=-1)
    caps = np.broadcast_to(np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]]), (n, 2, 3))
    normals = np.concatenate([side, caps], axis=1)
    offsets = np.concatenate([footprints.offsets, np.column_stack([z_hi, -np.asarray(z_lo)])], axis=1)
    return normals, offsets


@dataclass(frozen=True, eq=False)
class World:
    """Everything static: area, obstacles, goal regions.

    Obstacles are vertical prisms over convex footprints (cuboids are the footprints
    given as boxes).

    Attributes
    ----------
    area_lo, area_hi : (3,) surveillance area ``E`` (axis-aligned box).
    obstacle_lo, obstacle_hi : (n_obs, 3) bounding boxes (for a cuboid, its corners).
    obstacle_names : names, for messages.
    goals : goal regions by position; targets refer to them by index.
    prisms : the convex footprints of the obstacles given as prisms, or None when every
        obstacle is a cuboid; see :attr:`footprints`.
    normals, offsets : (n_obs, F + 2, 3), (n_obs, F + 2) half-space form (Sec. III-D).
    """

    name: str
    area_lo: np.ndarray
    area_hi: np.ndarray
    obstacle_lo: np.ndarray
    obstacle_hi: np.ndarray
    obstacle_names: tuple[str, ...]
    goals: tuple[GoalRegion, ...]
    prisms: Polygons | None = None

    @classmethod
    def of_prisms(cls, name, area_lo, area_hi, footprints: Polygons, z: np.ndarray, names, goals) -> "World":
        """A world whose obstacles are prisms over ``footprints`` from ``z[:, 0]`` to ``z[:, 1]``."""
        z = np.reshape(z, (-1, 2)).astype(float)
        lo, hi = np.column_stack([footprints.lo, z[:, 0]]), np.column_stack([footprints.hi, z[:, 1]])
        return cls(name, np.asarray(area_lo, float), np.asarray(area_hi, float), lo.reshape(-1, 3),
                   hi.reshape(-1, 3), tuple(names), tuple(goals), footprints)

    @cached_property
    def footprints(self) -> Polygons:
        """The obstacles' ground footprints (convex, counter-clockwise)."""
        if self.prisms is not None:
            return self.prisms
        return Polygons.boxes(self.obstacle_lo[:, :2], self.obstacle_hi[:, :2])

    @cached_property
    def _halfspaces(self) -> tuple[np.ndarray, np.ndarray]:
        return prism_halfspaces(self.footprints, self.obstacle_lo[:, 2], self.obstacle_hi[:, 2])

    @property
    def normals(self) -> np.ndarray:
        return self._halfspaces[0]

    @property
    def offsets(self) -> np.ndarray:
        return self._halfspaces[1]

    @property
    def n_obstacles(self) -> int:
        return self.obstacle_lo.shape[0]

    def in_area(self, points: np.ndarray) -> np.ndarray:
        """(...,) bool: point inside the closed area box."""
        p = np.asarray(points)
        return np.all((p >= self.area_lo) & (p <= self.area_hi), axis=-1)

    def on_ground(self, points: np.ndarray) -> np.ndarray:
        """Ground positions ``(..., 3)`` with z raised to the area's floor if below it: a
        ground target's z is ~1e-5 m either side of 0, and a point a hair below an
        obstacle's bottom face at the floor must not count as passing under it."""
        p = np.array(points, dtype=float)
        p[..., 2] = np.maximum(p[..., 2], self.area_lo[2])
        return p

    def in_obstacle(self, points: np.ndarray) -> np.ndarray:
        """(...,) bool: point inside any (closed) obstacle, i.e. Eq. (5) fails for one.
        Only the obstacles whose bounding boxes meet the points' are tested: a cloud of
        particles meets a few of a town's buildings."""
        points = np.asarray(points, dtype=float)
        if self.n_obstacles == 0 or points.size == 0:
            return np.zeros(points.shape[:-1], dtype=bool)
        flat = points.reshape(-1, 3)
        lo, hi = flat.min(axis=0), flat.max(axis=0)
        near = np.flatnonzero(np.all((self.obstacle_lo <= hi) & (self.obstacle_hi >= lo), axis=1))
        return inside_polytopes(points, self.normals[near], self.offsets[near]).any(axis=-1)

    def segment_blocked(self, p0: np.ndarray, p1: np.ndarray) -> np.ndarray:
        """(...,) bool: straight segment p0 -> p1 touches or crosses any obstacle.

        Two phases, so that a town costs what the obstacles near each segment cost: only
        the obstacles whose bounding boxes meet the box around every end are considered,
        nearest the ``p1`` ends first (where a target's line of sight is most often
        blocked), one at a time against the segments no earlier one blocked; of those,
        only the segments that, over their part at the obstacle's heights, pass within the
        circle holding its footprint are clipped exactly (Cyrus-Beck on the footprint's
        sides, as :func:`segments_hit_polytopes`)."""
        p0, p1 = np.asarray(p0, dtype=float), np.asarray(p1, dtype=float)
        shape = np.broadcast_shapes(p0.shape, p1.shape)[:-1]
        if self.n_obstacles == 0 or 0 in shape:
            return np.zeros(shape, dtype=bool)
        ends = (p0.reshape(-1, 3), p1.reshape(-1, 3))
        lo, hi = np.minimum(*(e.min(axis=0) for e in ends)), np.maximum(*(e.max(axis=0) for e in ends))
        near = np.flatnonzero(np.all((self.obstacle_lo <= hi) & (self.obstacle_hi >= lo), axis=1))
        centre = self.circles[0]
        near = near[np.argsort(np.hypot(*(centre[near] - ends[1][:, :2].mean(axis=0)).T))]
        out = np.zeros(int(np.prod(shape)), dtype=bool)
        a = np.broadcast_to(p0, shape + (3,)).reshape(-1, 3)
        d = np.broadcast_to(p1, shape + (3,)).reshape(-1, 3) - a
        live = np.arange(len(a))  # the segments no obstacle has blocked yet
        for o in near:  # the obstacles near these segments: a handful in a town
            q, s_lo, s_hi = self._clip(o, a[live], d[live])
            out[live[q[s_lo <= s_hi]]] = True
            live = np.delete(live, q[s_lo <= s_hi])
            if not len(live):
                break
        return out.reshape(shape)

    def fans_blocked(self, observers: np.ndarray, points: np.ndarray) -> np.ndarray:
        """``(C, P)`` bool: :meth:`segment_blocked` for the segment from every observer
        ``(C, 3)`` to every point ``(P, 3)``, the same verdicts for less work where a few
        observers see many points (:func:`uavsim.world.sight.fans_blocked`)."""
        from .sight import fans_blocked  # here: the convex hull needs scipy, reading a world does not

        return fans_blocked(self, observers, points)

    def _clip(self, o, a: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Segments ``a + t d`` (``(P, 3)`` each), ``t`` in [0, 1], against obstacle ``o`` (one
        index, or one per segment): the indices ``q`` of those that pass within its circle
        over their part at its heights, and for them the interval ``[s_lo, s_hi]`` of ``t``
        inside it (empty where ``s_lo > s_hi``)."""
        centre, radius = self.circles
        t_lo, t_hi = self._slab(o, a, d)
        dx, dy = d[:, 0], d[:, 1]
        rx, ry = centre[o, 0] - a[:, 0], centre[o, 1] - a[:, 1]
        dd = dx * dx + dy * dy
        t = np.clip((rx * dx + ry * dy) / np.where(dd > 0, dd, 1.0), t_lo, t_hi)
        q = np.flatnonzero(((rx - t * dx) ** 2 + (ry - t * dy) ** 2 <= radius[o] ** 2) & (t_lo <= t_hi))
        return (q, *self._sides(o if np.ndim(o) == 0 else o[q], a[q], d[q], t_lo[q], t_hi[q]))

    def meets(self, o, a: np.ndarray, d: np.ndarray) -> np.ndarray:
        """``(S,)`` bool: segment ``a + t d`` (``(S, 3)`` each, ``t`` in [0, 1]) touches or
        crosses obstacle ``o`` (one index, or ``(S,)``: one per segment); as
        :meth:`segment_blocked` tests each obstacle."""
        q, s_lo, s_hi = self._clip(o, a, d)
        out = np.zeros(len(a), dtype=bool)
        out[q[s_lo <= s_hi]] = True
        return out

    def _slab(self, o, a: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(t_lo, t_hi)``: where ``a + t d``, ``t`` in [0, 1], is at obstacle ``o``'s heights."""
        az, dz = a[:, 2], d[:, 2]
        z_lo, z_hi = self.obstacle_lo[o, 2], self.obstacle_hi[o, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            z0, z1 = (z_lo - az) / dz, (z_hi - az) / dz
        flat = dz == 0
        t_lo = np.where(flat, np.where((z_lo <= az) & (az <= z_hi), 0.0, 2.0), np.maximum(np.minimum(z0, z1), 0.0))
        t_hi = np.where(flat, 1.0, np.minimum(np.maximum(z0, z1), 1.0))
        return t_lo, t_hi

    def _sides(self, o, a: np.ndarray, d: np.ndarray, t_lo: np.ndarray, t_hi: np.ndarray):
        """Cyrus-Beck on the ground against obstacle ``o``'s footprint sides, within [t_lo, t_hi]."""
        nx, ny = self.footprints.normals[o, ..., 0], self.footprints.normals[o, ..., 1]  # padding repeats a side
        slack = self.footprints.offsets[o] - (nx * a[:, :1] + ny * a[:, 1:2])  # (S, F)
        rate = nx * d[:, :1] + ny * d[:, 1:2]
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = slack / rate
        s_hi = np.minimum(np.min(np.where(rate > 0, ratio, np.inf), axis=1), t_hi)
        s_lo = np.maximum(np.max(np.where(rate < 0, ratio, -np.inf), axis=1), t_lo)
        parallel_out = np.any((rate == 0) & (slack < 0), axis=1)  # parallel to a side, outside it
        return np.where(parallel_out, np.inf, s_lo), s_hi

    @cached_property
    def circles(self) -> tuple[np.ndarray, np.ndarray]:
        """``(centres (n_obs, 2), radii (n_obs,))``: circles on the ground holding each
        footprint (centred on its bounding box, a little larger: a broad phase)."""
        centre = 0.5 * (self.obstacle_lo[:, :2] + self.obstacle_hi[:, :2])
        half_diagonal = 0.5 * np.linalg.norm(self.obstacle_hi[:, :2] - self.obstacle_lo[:, :2], axis=1)
        return centre, half_diagonal * (1 + 1e-9) + 1e-9

    def ground(self, margin: float, band: float | None = None) -> tuple[np.ndarray, Polygons]:
        """``(kept, polygons)``: :func:`ground_footprints` of this world's obstacles."""
        return ground_footprints(self.footprints, self.obstacle_lo[:, 2], self.obstacle_hi[:, 2], margin,
                                 GROUND_BAND_M if band is None else band)


# --------------------------------------------------------------------------- ground obstacles
GROUND_BAND_M = 1.0  # |z| band of ground targets; the guidance model drops obstacles that miss it


def ground_footprints(footprints: Polygons, z_lo: np.ndarray, z_hi: np.ndarray, margin: float,
                      band: float = GROUND_BAND_M) -> tuple[np.ndarray, Polygons]:
    """The obstacles a ground target must avoid, as inflated convex polygons.

    Every obstacle's footprint is inflated by ``margin`` (each edge pushed out along its
    normal: :meth:`Polygons.inflated`; the guidance model's ``delta = v_max dt / 2 +
    clearance``); one whose inflated z-slab ``[z_min - margin, z_max + margin]`` does not
    cover the ground band ``|z| <= band`` cannot meet a ground target and is dropped (as
    :mod:`uavsim.guidance.model` does).

    Parameters
    ----------
    footprints : the obstacles' footprints; z_lo, z_hi : (n,) their bottoms and tops;
    margin : delta (m).

    Returns
    -------
    kept : (k,) indices of the obstacles kept; the k inflated footprints.
    """
    z_lo, z_hi = np.reshape(z_lo, -1), np.reshape(z_hi, -1)
    kept = np.flatnonzero((z_lo - margin < -band) & (z_hi + margin > band))
    return kept, footprints.take(kept).inflated(margin)


# A world file, table by table: every key the reader accepts (uavsim.config.load_world reads
# through these; docs/world-format.md is generated from them).  An obstacle is a cuboid
# (min_m, max_m) or a vertical prism (footprint_m, z_m), not both.
WORLD_KEYS = {
    "(top level)": (Spec("name", "string", "the world's label", derived="the file's name without .toml"),),
    "[area]": (
        Spec("min_m", "array", "the area's lower corner [x, y, z]; z <= 0: the ground z = 0, where the targets "
             "and goals are, lies in it", unit="m", shape=(3,)),
        Spec("max_m", "array", "the upper corner [x, y, z], above min_m in every axis", unit="m", shape=(3,)),
    ),
    "[[obstacles]]": (
        Spec("name", "string", "the obstacle's label, unique", derived="obstacle0, obstacle1, ... by position"),
        Spec("min_m", "array", "a cuboid's lower corner [x, y, z] (with max_m), inside the area", unit="m",
             shape=(3,), derived="required for a cuboid"),
        Spec("max_m", "array", "a cuboid's upper corner, above min_m in every axis", unit="m", shape=(3,),
             derived="required for a cuboid"),
        Spec("footprint_m", "array", "a vertical prism's convex footprint [[x, y], ...], counter-clockwise (with "
             "z_m)", unit="m", shape=(None, 2), derived="required for a prism"),
        Spec("z_m", "array", "the prism's [z_min, z_max], z_max above z_min", unit="m", shape=(2,),
             derived="required for a prism"),
    ),
    "[[goals]]": (
        Spec("name", "string", "the goal region's label, unique (targets name it)"),
        Spec("center_m", "array", "the rectangle's centre [x, y] (its centroid G_o, Eq. 7), on the ground, "
             "outside obstacles", unit="m", shape=(2,)),
        Spec("size_m", "array", "its width and depth [dx, dy], positive; the rectangle lies in the area", unit="m",
             shape=(2,)),
    ),
}
