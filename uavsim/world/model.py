"""Surveillance area, cuboid obstacles, goal regions and the UAV operating region.

Model ([Papaioannou2023] Sec. III-D): obstacle n is a cuboid given by six
half-spaces with outward unit normals ``a_i^n`` and offsets ``b_i^n``; a point p is
inside it when ``a_i^n . p <= b_i^n`` for all six faces, and a collision is avoided
when Eq. (5) holds, ``exists i: a_i^n . p > b_i^n``.  Obstacles are closed sets here:
a point on a face is inside (touching is a collision).

Shapes: ``normals (n_obs, 6, 3)``, ``offsets (n_obs, 6)``, points ``(..., 3)``.
All tests broadcast over leading axes; none loops in Python over points.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

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
class World:
    """Everything static: area, obstacles, goal regions.

    Attributes
    ----------
    area_lo, area_hi : (3,) surveillance area ``E`` (axis-aligned box).
    obstacle_lo, obstacle_hi : (n_obs, 3) cuboid corners.
    normals, offsets : (n_obs, 6, 3), (n_obs, 6) half-space form (Sec. III-D).
    obstacle_names : names, for messages.
    goals : goal regions by position; targets refer to them by index.
    """

    name: str
    area_lo: np.ndarray
    area_hi: np.ndarray
    obstacle_lo: np.ndarray
    obstacle_hi: np.ndarray
    obstacle_names: tuple[str, ...]
    goals: tuple[GoalRegion, ...]

    @cached_property
    def normals(self) -> np.ndarray:
        return cuboid_halfspaces(self.obstacle_lo, self.obstacle_hi)[0]

    @cached_property
    def offsets(self) -> np.ndarray:
        return cuboid_halfspaces(self.obstacle_lo, self.obstacle_hi)[1]

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
        """(...,) bool: point inside any (closed) obstacle, i.e. Eq. (5) fails for one."""
        if self.n_obstacles == 0:
            return np.zeros(np.shape(points)[:-1], dtype=bool)
        return inside_polytopes(np.asarray(points), self.normals, self.offsets).any(axis=-1)

    def segment_blocked(self, p0: np.ndarray, p1: np.ndarray) -> np.ndarray:
        """(...,) bool: straight segment p0 -> p1 touches or crosses any obstacle."""
        shape = np.broadcast_shapes(np.shape(p0), np.shape(p1))[:-1]
        if self.n_obstacles == 0:
            return np.zeros(shape, dtype=bool)
        hit = segments_hit_polytopes(np.asarray(p0), np.asarray(p1), self.normals, self.offsets)
        return hit.any(axis=-1)


# --------------------------------------------------------------------------- ground free space
GROUND_BAND_M = 1.0  # |z| band of ground targets; the guidance model drops obstacles that miss it


def ground_footprints(
    obstacle_lo: np.ndarray, obstacle_hi: np.ndarray, margin: float, band: float = GROUND_BAND_M
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The obstacles a ground target must avoid, as inflated (x, y) rectangles.

    Every obstacle is inflated by ``margin`` per axis (the guidance model's
    ``delta = v_max dt / 2 + clearance``); one whose inflated z-slab
    ``[z_min - margin, z_max + margin]`` does not cover the ground band ``|z| <= band``
    cannot meet a ground target and is dropped (as :mod:`uavsim.guidance.model` does).

    Parameters
    ----------
    obstacle_lo, obstacle_hi : (n, 3) cuboid corners; margin : delta (m).

    Returns
    -------
    kept : (k,) indices of the obstacles kept; lo, hi : (k, 2) inflated footprints.
    """
    obstacle_lo, obstacle_hi = np.reshape(obstacle_lo, (-1, 3)), np.reshape(obstacle_hi, (-1, 3))
    kept = np.flatnonzero((obstacle_lo[:, 2] - margin < -band) & (obstacle_hi[:, 2] + margin > band))
    return kept, obstacle_lo[kept, :2] - margin, obstacle_hi[kept, :2] + margin


@dataclass(frozen=True, eq=False)
class FreeSpace:
    """Exact connectivity of the plane area minus closed axis-aligned rectangles.

    The rectangles' edges (clipped to the area), the area's and any marked regions'
    edges cut the area into a compressed grid of cells.  No rectangle edge crosses a
    cell, so the open cell lies wholly inside an open rectangle or wholly outside every
    closed one: each cell is blocked or free, with no raster error.  Free cells are
    joined through shared edges of positive length (4-neighbours); two cells meeting at
    a corner are not joined, so closed rectangles touching at a corner or along an edge
    close the passage between them (a passage of zero width).

    Attributes
    ----------
    xs, ys : (nx + 1,), (ny + 1,) grid lines; owner : (nx, ny) index of the first
    rectangle covering each cell, -1 if free; labels : (nx, ny) free component of each
    cell (1, 2, ...), 0 if blocked; blocked_labels : (nx, ny) component of blocked cells;
    lo, hi : (n, 2) the rectangles.
    """

    xs: np.ndarray
    ys: np.ndarray
    owner: np.ndarray
    labels: np.ndarray
    blocked_labels: np.ndarray
    lo: np.ndarray
    hi: np.ndarray

    def _cell(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        p = np.asarray(points, dtype=float)
        i = np.clip(np.searchsorted(self.xs, p[..., 0], side="right") - 1, 0, len(self.xs) - 2)
        j = np.clip(np.searchsorted(self.ys, p[..., 1], side="right") - 1, 0, len(self.ys) - 2)
        return i, j

    def is_free(self, points: np.ndarray) -> np.ndarray:
        """(...,) bool: point outside every closed rectangle."""
        p = np.asarray(points, dtype=float)[..., None, :2]
        return ~np.any(np.all((p >= self.lo) & (p <= self.hi), axis=-1), axis=-1)

    def start_labels(self, point: np.ndarray) -> set[int]:
        """Free components a path from ``point (2,)`` can enter.

        A free point is in one component.  A point inside the rectangles (a start inside
        a safety margin) may leave them: every free component bordering the blocked
        component around it counts.
        """
        i, j = self._cell(point)
        if self.is_free(point) or self.labels[i, j]:
            return {int(self.labels[i, j])} - {0}
        around = _dilate(self.blocked_labels == self.blocked_labels[i, j])
        return set(np.unique(self.labels[around]).tolist()) - {0}

    def region_labels(self, lo: np.ndarray, hi: np.ndarray) -> set[int]:
        """Free components meeting the open rectangle ``(lo, hi)`` (its edges must be grid lines)."""
        cells = self._cells_in(lo, hi)
        return set(np.unique(self.labels[cells]).tolist()) - {0}

    def covering(self, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """Indices of the rectangles overlapping the open rectangle ``(lo, hi)``."""
        return np.flatnonzero(np.all((self.lo < hi) & (self.hi > lo), axis=1))

    def border(self, labels: set[int]) -> np.ndarray:
        """Indices of the rectangles whose cells touch the free components ``labels``."""
        near = _dilate(np.isin(self.labels, list(labels))) & (self.owner >= 0)
        return np.unique(self.owner[near])

    def _cells_in(self, lo, hi) -> np.ndarray:
        cx, cy = 0.5 * (self.xs[1:] + self.xs[:-1]), 0.5 * (self.ys[1:] + self.ys[:-1])
        return ((cx > lo[0]) & (cx < hi[0]))[:, None] & ((cy > lo[1]) & (cy < hi[1]))[None, :]


def _dilate(mask: np.ndarray) -> np.ndarray:
    """The cells of ``mask`` and their 4-neighbours (shared edge of positive length)."""
    out = mask.copy()
    out[1:] |= mask[:-1]
    out[:-1] |= mask[1:]
    out[:, 1:] |= mask[:, :-1]
    out[:, :-1] |= mask[:, 1:]
    return out


def free_space(
    lo: np.ndarray, hi: np.ndarray, area_lo: np.ndarray, area_hi: np.ndarray, regions=()
) -> FreeSpace:
    """The compressed grid of :class:`FreeSpace` and its connected components.

    Parameters
    ----------
    lo, hi : (n, 2) closed rectangles (e.g. from :func:`ground_footprints`).
    area_lo, area_hi : (2,) the area (paths stay inside it).
    regions : (lo, hi) pairs whose edges become grid lines too (goal regions), so that
        :meth:`FreeSpace.region_labels` is exact for them.
    """
    lo, hi = np.reshape(lo, (-1, 2)).astype(float), np.reshape(hi, (-1, 2)).astype(float)
    a_lo, a_hi = np.asarray(area_lo, dtype=float)[:2], np.asarray(area_hi, dtype=float)[:2]
    marks = [np.clip(lo, a_lo, a_hi), np.clip(hi, a_lo, a_hi), a_lo[None], a_hi[None]]
    marks += [np.clip(np.reshape(r, (1, 2)), a_lo, a_hi) for pair in regions for r in pair]
    pts = np.vstack(marks)
    xs, ys = np.unique(pts[:, 0]), np.unique(pts[:, 1])
    cx, cy = 0.5 * (xs[1:] + xs[:-1]), 0.5 * (ys[1:] + ys[:-1])
    inside = (((cx[:, None] > lo[:, 0]) & (cx[:, None] < hi[:, 0]))[:, None, :]
              & ((cy[:, None] > lo[:, 1]) & (cy[:, None] < hi[:, 1]))[None, :, :])  # (nx, ny, n)
    blocked = inside.any(axis=-1)
    owner = np.where(blocked, np.argmax(inside, axis=-1) if len(lo) else 0, -1)
    return FreeSpace(xs, ys, owner, label_grid(~blocked), label_grid(blocked), lo, hi)


def label_grid(mask: np.ndarray) -> np.ndarray:
    """Connected components of the True cells of a 2-D ``mask`` through shared edges
    (4-neighbours): ``(nx, ny)`` int, 1, 2, ... numbered in the order of each component's
    first cell in C order, 0 where False -- what ``scipy.ndimage.label(mask)`` returns
    (tests/test_world.py checks it), in numpy only, so that reading a mission does not
    import scipy.

    Union-find over the grid's edges, vectorised: each round hooks every root to the
    smallest root across an edge, then compresses every path; at the end each
    component's root is its smallest flat index.
    """
    mask = np.asarray(mask, dtype=bool)
    idx = np.arange(mask.size).reshape(mask.shape)
    pairs = [(idx[:-1][mask[:-1] & mask[1:]], idx[1:][mask[:-1] & mask[1:]]),
             (idx[:, :-1][mask[:, :-1] & mask[:, 1:]], idx[:, 1:][mask[:, :-1] & mask[:, 1:]])]
    a = np.concatenate([p[0] for p in pairs])
    b = np.concatenate([p[1] for p in pairs])
    parent = idx.ravel().copy()
    while True:
        ra, rb = parent[a], parent[b]
        apart = ra != rb
        if not apart.any():
            break
        ra, rb = ra[apart], rb[apart]
        np.minimum.at(parent, np.maximum(ra, rb), np.minimum(ra, rb))
        while True:  # compress: every cell points at its root
            up = parent[parent]
            if np.array_equal(up, parent):
                break
            parent = up
        a, b = a[apart], b[apart]
    roots = parent[mask.ravel()]
    first = np.unique(roots)  # ascending: the order of each component's first cell
    out = np.zeros(mask.size, dtype=np.int32)
    out[mask.ravel()] = np.searchsorted(first, roots) + 1
    return out.reshape(mask.shape)
