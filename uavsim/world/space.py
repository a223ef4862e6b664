"""Exact connectivity of the ground's free space: the area minus closed convex polygons.

The polygons (the inflated obstacles of :func:`uavsim.world.model.ground_footprints`)
are closed: a path may not touch them.  Their union is computed by GEOS through shapely
([shapely], the library behind most Python GIS code; robust overlays, where a hand-made
union of hundreds of polygons would not be), and the free space is the area minus it.
Its connected components are the polygons of that difference: two free regions that
meet only at a point (where two obstacles touch at a corner) are two components, so a
passage of zero width is closed, as it is for the guidance model, whose points must lie
outside every closed inflated obstacle.

shapely is imported when a free space is made (a world with ground obstacles), not when
a mission is read without one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .model import Polygons

AREA_TOL = 1e-9  # relative: an overlap smaller than this times the area's size squared is a touch


def shapes(polygons: Polygons) -> list:
    """The polygons as shapely Polygons (their real vertices)."""
    import shapely

    return [shapely.Polygon(v[:k]) for v, k in zip(polygons.vertices, polygons.sides)]


@dataclass(frozen=True, eq=False)
class FreeSpace:
    """The free components of the area outside closed convex polygons.

    Attributes
    ----------
    polygons : the closed obstacles; free : shapely Polygons, component k + 1 is free[k];
    blocked : shapely Polygons, the connected components of the obstacles' union;
    tol : areas below it count as zero (m^2).
    """

    polygons: Polygons
    free: tuple
    blocked: tuple
    tol: float

    def is_free(self, points: np.ndarray) -> np.ndarray:
        """(...,) bool: point outside every closed polygon."""
        if len(self.polygons) == 0:
            return np.ones(np.shape(points)[:-1], dtype=bool)
        return ~self.polygons.contains(np.asarray(points, dtype=float)).any(axis=-1)

    def _labels(self, geometry, touching: bool = False) -> set[int]:
        import shapely

        if touching:
            hit = [shapely.intersects(f, geometry) for f in self.free]
        else:
            hit = [shapely.intersection(f, geometry).area > self.tol for f in self.free]
        return {k + 1 for k, h in enumerate(hit) if h}

    def start_labels(self, point: np.ndarray) -> set[int]:
        """Free components a path from ``point (2,)`` can enter.

        A free point is in one component.  A point inside the polygons (a start inside a
        safety margin) may leave them: every free component bordering the connected
        blocked region around it counts.
        """
        import shapely

        p = shapely.Point(*np.asarray(point, dtype=float)[:2])
        if self.is_free(np.asarray(point, dtype=float)[:2]):
            return self._labels(p, touching=True)
        around = [b for b in self.blocked if shapely.intersects(b, p)]
        return set().union(*(self._labels(b.boundary, touching=True) for b in around))

    def region_labels(self, lo: np.ndarray, hi: np.ndarray) -> set[int]:
        """Free components meeting the open rectangle ``(lo, hi)`` in an area."""
        import shapely

        return self._labels(shapely.box(*lo[:2], *hi[:2]))

    def covering(self, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """Indices of the polygons overlapping the open rectangle ``(lo, hi)``."""
        import shapely

        rect = shapely.box(*lo[:2], *hi[:2])
        return np.array([k for k, s in enumerate(shapes(self.polygons)) if s.intersection(rect).area > self.tol],
                        dtype=int)

    def border(self, labels: set[int]) -> np.ndarray:
        """Indices of the polygons touching the free components ``labels``."""
        import shapely

        parts = [self.free[k - 1] for k in labels]
        if not parts:
            return np.zeros(0, dtype=int)
        region = shapely.unary_union(parts)
        return np.array([k for k, s in enumerate(shapes(self.polygons)) if shapely.intersects(s, region)], dtype=int)


def free_space(polygons: Polygons, area_lo: np.ndarray, area_hi: np.ndarray) -> FreeSpace:
    """The free space of the area ``[area_lo, area_hi]`` (x, y) outside ``polygons``."""
    import shapely

    a_lo, a_hi = np.asarray(area_lo, dtype=float)[:2], np.asarray(area_hi, dtype=float)[:2]
    area = shapely.box(*a_lo, *a_hi)
    tol = AREA_TOL * float(np.max(a_hi - a_lo)) ** 2
    union = shapely.unary_union(shapes(polygons)) if len(polygons) else shapely.Polygon()
    free = area.difference(union)
    return FreeSpace(polygons, tuple(_parts(free, tol)), tuple(_parts(union, 0.0)), tol)


def _parts(geometry, tol: float) -> list:
    """The polygons of a (multi)polygon with an area above ``tol``."""
    parts = getattr(geometry, "geoms", [geometry])
    return [g for g in parts if g.geom_type == "Polygon" and g.area > tol]


@dataclass(frozen=True, eq=False)
class DepthGrid:
    """How deep a point lies inside closed convex polygons or outside the area, sampled on a
    grid: the largest over the polygons of ``min_i (b_i - a_i . p)`` where positive (0
    outside every polygon), and a point outside the area ``[lo, hi]`` as deep as it is
    outside, up to ``pad`` (the grid reaches ``pad`` beyond the area; a point farther out
    reads its edge).  A lookup takes the sample at the nearest grid point, so it is within
    ``res / sqrt(2)`` of the exact depth (the depth is 1-Lipschitz).

    Attributes
    ----------
    origin : (2,) the grid's first point, ``lo - pad``; res : the grid step (m); depth :
    (nx, ny) float32 samples at ``origin + res * (i, j)``.
    """

    origin: np.ndarray
    res: float
    depth: np.ndarray

    @classmethod
    def build(cls, polygons: Polygons, lo: np.ndarray, hi: np.ndarray, res: float = 1.0, pad: float = 10.0
              ) -> "DepthGrid":
        """Each polygon is sampled over the grid points of its bounding box only (a loop
        over the polygons, once per world)."""
        lo, hi = np.asarray(lo, float)[:2], np.asarray(hi, float)[:2]
        origin = lo - pad
        shape = np.ceil((hi + pad - origin) / res).astype(int) + 1
        axes = [origin[k] + res * np.arange(shape[k]) for k in (0, 1)]
        outside = np.maximum.outer(np.maximum(lo[0] - axes[0], axes[0] - hi[0]),
                                   np.maximum(lo[1] - axes[1], axes[1] - hi[1]))
        depth = np.maximum(outside, 0.0).astype(np.float32)
        for v, a, b in zip(polygons.vertices, polygons.normals, polygons.offsets):
            i0 = np.clip(np.floor((v.min(axis=0) - origin) / res).astype(int), 0, shape - 1)
            i1 = np.clip(np.ceil((v.max(axis=0) - origin) / res).astype(int), 0, shape - 1)
            pts = np.stack(np.meshgrid(axes[0][i0[0]:i1[0] + 1], axes[1][i0[1]:i1[1] + 1], indexing="ij"), axis=-1)
            box = depth[i0[0]:i1[0] + 1, i0[1]:i1[1] + 1]
            np.maximum(box, (b - pts @ a.T).min(axis=-1), out=box)
        return cls(origin, float(res), depth)

    def __call__(self, points: np.ndarray) -> np.ndarray:
        """``(...)`` the depth at ``points (..., 2+)`` (x, y first)."""
        idx = np.rint((np.asarray(points)[..., :2] - self.origin) / self.res).astype(np.intp)
        nx, ny = self.depth.shape
        flat = np.clip(idx[..., 0], 0, nx - 1) * ny + np.clip(idx[..., 1], 0, ny - 1)
        return self.depth.ravel()[flat]
