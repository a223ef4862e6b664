"""Lines of sight fanning out from a few observers to many points: which are blocked.

:func:`fans_blocked` gives :meth:`~uavsim.world.World.segment_blocked`'s verdict for every
(observer, point) segment: the UAV's candidate moves against the targets' particles, the
decision under line of sight.  It is exact, and cheaper than testing every segment,
because of two facts about a convex obstacle O and a point p (a ground target):

* **The fan misses O.**  The part of the segment ``p -> s`` at O's heights is
  ``p + t (s - p)`` for ``t`` in ``[t_min, t_max]`` (the heights at which the segment
  rises through O's slab, taken over all observers).  For every observer in the
  observers' convex hull H those parts lie, on the ground, in the convex polygon R
  spanned by H scaled about p by ``t_min`` and ``t_max``.  If a separating axis parts R
  from O's footprint, no segment of the fan meets O.  Two kinds of axis are tested: O's
  sides (every vertex of R beyond one side), and, where p lies outside H, the two sides
  of the wedge from p round H (the footprint wholly beyond one).  A capsule about the
  fan's axis, against the circle round the footprint, culls first.
* **O hides p from all of H.**  The observers s for which ``[p, s]`` meets O form a
  convex set: if ``[p, s1]`` meets O at ``o1`` and ``[p, s2]`` at ``o2``, then
  ``[p, s]`` for any s between s1 and s2 crosses ``[o1, o2]``, which lies in O.  So if O
  blocks p from every vertex of H, it blocks p from every observer.  This is tried only
  where O's footprint, seen from p, spans every direction to H (as it must).

The segments left (a pair of point and obstacle neither fact settles) are tested by
:meth:`~uavsim.world.World.meets`, as :meth:`~uavsim.world.World.segment_blocked` tests
them, for the observers in a direction from p (on the ground) that the footprint spans: the
segment to any other misses it.  The verdicts are the same as that method's: the two facts hold exactly, the culls
keep a margin of :data:`MARGIN_M`, and only a segment that touches an obstacle within
rounding could come out differently.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from ..sensing import wrap_angle

MARGIN_M = 1e-7  # a separating axis must part the two sets by this much (rounding)


def fans_blocked(world, observers: np.ndarray, points: np.ndarray) -> np.ndarray:
    """``(C, P)`` bool: the segment ``observers[c] -> points[p]`` touches or crosses an
    obstacle of ``world`` (a :class:`~uavsim.world.World`); observers ``(C, 3)``, points
    ``(P, 3)``.  See the module docstring."""
    observers, points = np.asarray(observers, float).reshape(-1, 3), np.asarray(points, float).reshape(-1, 3)
    out = np.zeros((len(observers), len(points)), dtype=bool)
    if world.n_obstacles == 0 or out.size == 0:
        return out
    hull = hull_rows(observers)
    fan = _Fan(observers[hull, :2], points[:, :2])
    pt, ob, lo, hi = _pairs_near(world, observers, points, hull, fan)
    if not len(pt):
        return out
    if len(hull) == len(observers):  # the hull's verdicts are every observer's
        pair, vertex = np.nonzero(_blocked_from_hull(world, observers[hull], points, pt, ob))
        out[hull[vertex], pt[pair]] = True
        return out
    may = fan.spanned(pt, lo, hi)  # the footprint spans every direction to the hull, as it must to hide p from it
    full = np.zeros(len(pt), dtype=bool)
    full[may] = _blocked_from_hull(world, observers[hull], points, pt[may], ob[may]).all(axis=1)
    hidden = np.zeros(len(points), dtype=bool)
    hidden[pt[full]] = True
    out[:, hidden] = True
    rest = ~hidden[pt]
    pt, ob, lo, hi = pt[rest], ob[rest], lo[rest], hi[rest]
    pair, obs = np.nonzero(fan.within(observers[:, :2], pt, lo, hi))
    hit = world.meets(ob[pair], observers[obs], points[pt[pair]] - observers[obs])
    out[obs[hit], pt[pair[hit]]] = True
    return out


def hull_rows(observers: np.ndarray) -> np.ndarray:
    """Indices of the observers ``(C, 3)`` at the vertices of their convex hull (in the
    ground plane when they share a height, counter-clockwise there); all of them when
    the hull is degenerate or there are at most three."""
    if len(observers) <= 3:
        return np.arange(len(observers))
    try:
        if np.ptp(observers[:, 2]) == 0:
            return ConvexHull(observers[:, :2]).vertices
        return ConvexHull(observers).vertices
    except QhullError:  # collinear or coincident observers
        return np.arange(len(observers))


def _heights(observers: np.ndarray, zp: np.ndarray, bottom: np.ndarray, top: np.ndarray):
    """``(t_min, t_max)``: the parameters ``t`` (0 at the point, 1 at an observer) at which
    any observer's segment from a point at height ``zp`` can be between heights ``bottom``
    and ``top`` (an obstacle's; all three broadcast); ``[0, 1]`` unless every observer is
    above the point."""
    z_lo, z_hi = observers[:, 2].min(), observers[:, 2].max()
    above = zp < z_lo
    rise_lo, rise_hi = np.where(above, z_lo - zp, 1.0), np.where(above, z_hi - zp, 1.0)
    t_min = np.where(above & (bottom > zp), (bottom - zp) / rise_hi, 0.0)
    t_max = np.where(above, np.minimum((top - zp) / rise_lo, 1.0), 1.0)
    return t_min, t_max


def _pairs_near(world, observers: np.ndarray, points: np.ndarray, hull: np.ndarray, fan: "_Fan"):
    """``(pt, ob, lo, hi)``: the (point, obstacle) pairs no separating axis parts (module
    docstring), the capsule test first, and the directions their footprints span
    (:meth:`_Fan.span`)."""
    centre, radius = world.circles
    c0 = 0.5 * (observers[:, :2].min(axis=0) + observers[:, :2].max(axis=0))
    reach = np.sqrt(((observers[:, :2] - c0) ** 2).sum(axis=1).max())
    t_min, t_max = _heights(observers, points[:, 2:], world.obstacle_lo[None, :, 2], world.obstacle_hi[None, :, 2])
    ax_x, ax_y = c0[0] - points[:, :1], c0[1] - points[:, 1:2]  # (P, 1): from the point to the observers' centre
    rel_x, rel_y = centre[:, 0] - points[:, :1], centre[:, 1] - points[:, 1:2]  # (P, O)
    along = ax_x * ax_x + ax_y * ax_y
    t = np.clip((rel_x * ax_x + rel_y * ax_y) / np.where(along > 0, along, 1.0), t_min, t_max)
    gap = (rel_x - t * ax_x) ** 2 + (rel_y - t * ax_y) ** 2
    pt, ob = np.nonzero((t_min <= t_max) & (t_max >= 0) & (gap <= (radius + t_max * reach + MARGIN_M) ** 2))
    keep = ~_apart_by_sides(world, observers[hull, :2], points[pt, :2], ob, t_min[pt, ob], t_max[pt, ob])
    pt, ob = pt[keep], ob[keep]
    lo, hi = fan.span(world.footprints.vertices[ob], pt)
    keep = ~fan.apart(pt, lo, hi)
    return pt[keep], ob[keep], lo[keep], hi[keep]


def _apart_by_sides(world, hull: np.ndarray, p: np.ndarray, ob: np.ndarray, t_min: np.ndarray,
                    t_max: np.ndarray) -> np.ndarray:
    """bool per pair: one side of the footprint has every vertex of the fan's polygon R
    beyond it (module docstring).  hull (V, 2) the observers' hull on the ground; p (Q, 2)
    the points.  R's vertices are ``p + t (h - p)`` for t in {t_min, t_max} (both >= 0),
    so its least offset along a normal n is ``n.p + min over t of t (min_h n.h - n.p)``."""
    fp = world.footprints
    n_x, n_y = fp.normals[..., 0], fp.normals[..., 1]  # (n_obs, F)
    least = np.min(n_x[..., None] * hull[:, 0] + n_y[..., None] * hull[:, 1], axis=2)[ob]  # (Q, F)
    n_p = n_x[ob] * p[:, :1] + n_y[ob] * p[:, 1:]
    low = n_p + np.minimum(t_min[:, None] * (least - n_p), t_max[:, None] * (least - n_p))
    return np.any(low > fp.offsets[ob] + MARGIN_M, axis=1)


class _Fan:
    """Directions on the ground from each point ``(P, 2)`` as angles in (-pi, pi] from the
    direction to the centre of the observers' hull ``(V, 2)``, and the hull's interval of
    them: ``[lo, hi]`` per point, a wedge only where ``hi - lo < pi`` (p outside the hull).
    A footprint's directions from p (:meth:`span`) form an interval of width under pi only
    where the footprint lies wholly on one side of p; then every direction into it is
    within it.  Intervals are compared with a margin of ``TURN_MARGIN`` rad."""

    TURN_MARGIN = 1e-9

    def __init__(self, hull: np.ndarray, points: np.ndarray):
        self.points = points
        self.ref = np.arctan2(hull[:, 1].mean() - points[:, 1], hull[:, 0].mean() - points[:, 0])[:, None]  # (P, 1)
        turn = self.turn(hull, np.arange(len(points)))
        self.lo, self.hi = turn.min(axis=1), turn.max(axis=1)

    def turn(self, xy: np.ndarray, pt: np.ndarray) -> np.ndarray:
        """``(Q, K)``: directions from ``points[pt]`` to ``xy`` (``(K, 2)`` or ``(Q, K, 2)``)."""
        p = self.points[pt]
        return wrap_angle(np.arctan2(xy[..., 1] - p[:, 1:], xy[..., 0] - p[:, :1]) - self.ref[pt])

    def span(self, corners: np.ndarray, pt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(lo, hi)`` per pair: the least and largest direction from ``points[pt]`` to the
        footprint ``corners (Q, F, 2)``."""
        turn = self.turn(corners, pt)
        return turn.min(axis=1), turn.max(axis=1)

    def apart(self, pt: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """bool per pair: the footprint's directions miss the wedge (module docstring: a
        side of the wedge parts them)."""
        m = self.TURN_MARGIN
        both = (self.hi[pt] - self.lo[pt] < np.pi) & (hi - lo < np.pi)
        return both & ((hi < self.lo[pt] - m) | (lo > self.hi[pt] + m))

    def spanned(self, pt: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """bool per pair: the footprint spans every direction to the hull (or surrounds p)."""
        m = self.TURN_MARGIN
        return (hi - lo >= np.pi) | ((lo <= self.lo[pt] + m) & (hi >= self.hi[pt] - m))

    def within(self, observers: np.ndarray, pt: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """``(Q, C)`` bool: observer c (``(C, 2)`` on the ground) lies in a direction from
        ``points[pt]`` that the footprint spans, or right above the point, or the footprint
        surrounds it: the only observers whose segment to the point it can meet."""
        m = self.TURN_MARGIN
        to_obs = self.turn(observers, pt)
        above = np.all(observers[None] == self.points[pt, None], axis=2)
        return (hi - lo >= np.pi)[:, None] | ((to_obs >= lo[:, None] - m) & (to_obs <= hi[:, None] + m)) | above


def _blocked_from_hull(world, hull: np.ndarray, points: np.ndarray, pt: np.ndarray, ob: np.ndarray) -> np.ndarray:
    """``(pairs, V)`` bool: obstacle ``ob`` blocks ``points[pt]`` from hull vertex v ``(V, 3)``."""
    v = len(hull)
    a = np.broadcast_to(hull, (len(pt), v, 3)).reshape(-1, 3)
    d = (points[pt, None, :] - hull[None]).reshape(-1, 3)
    return world.meets(np.repeat(ob, v), a, d).reshape(-1, v)
