"""Surveillance area, cuboid obstacles, goal regions and the UAV operating region.

Model (004_22b452551a772073.txt Sec. III-D): obstacle n is a cuboid given by six
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
    004_22b452551a772073.txt Sec. III-D, the six inequalities before Eq. (5).
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
    004_22b452551a772073.txt Sec. III-A and Eq. (7) (centroid ``G_o^j``).
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
