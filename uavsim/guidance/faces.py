"""Which obstacle faces can matter: reachable sets, pruning, tight big-M, start heuristics.

Obstacle j has F faces (a convex footprint's edges, padded: :class:`uavsim.world.Polygons`),
face i with outward unit normal ``a_ji`` (:class:`Faces`); ``y[r, j, i]`` (step tau =
r + 2) follows the paper: 1 switches the face off, and at least one face per obstacle and
step stays on (Eq. 8e).  A padded face repeats face 0 and is never switched on.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

AXES = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]])  # +x, -x, +y, -y: a box's supports


@dataclass(frozen=True, eq=False)
class Faces:
    """The avoidance faces of the kept obstacles: ``normals (n, F, 2)`` outward unit,
    ``valid (n, F)`` (False: padding), ``neighbours (n, F, 2)`` the faces meeting each
    face at its ends (a path round a corner passes from one to the other)."""

    normals: np.ndarray
    valid: np.ndarray
    neighbours: np.ndarray

    @property
    def width(self) -> int:
        return self.normals.shape[1]

    def slack(self, points: np.ndarray, b: np.ndarray) -> np.ndarray:
        """(T-1, n, F) signed clearance ``a_i . p - b_i`` of ``points (T-1, 2)`` (>= 0:
        beyond face i); ``-inf`` on padded faces.  Written out over the two axes, in
        place: einsum and ``np.where`` took twice as long (it runs for every node)."""
        n, f = self.valid.shape
        flat = self.normals.reshape(n * f, 2)
        s = points[:, :1] * flat[:, 0]
        s += points[:, 1:] * flat[:, 1]
        s = s.reshape(len(points), n, f)
        s -= b
        s[:, ~self.valid] = -np.inf
        return s


@dataclass(frozen=True, eq=False)
class Bounds:
    """Where ``p_tau`` (tau = 2..T) can be: ``box_lo, box_hi (T-1, 2)`` a bounding box
    per step, and ``lo, hi (T-1, n, F)`` bounds of ``a_i . p_tau`` per face."""

    box_lo: np.ndarray
    box_hi: np.ndarray
    lo: np.ndarray
    hi: np.ndarray

    @property
    def boxes(self) -> tuple[np.ndarray, np.ndarray]:
        return self.box_lo, self.box_hi


@dataclass(frozen=True)
class Reach:
    """Where ``p_tau`` (tau = 2..T) can be, for every plan at least as good as an incumbent.

    * force: per axis, ``p_tau`` lies within ``F sum_k g_tau,k`` of the zero-force
      response ``p_t + c_tau v_t`` (``g`` the sensitivity of ``p_tau`` to ``u_k``);
    * speed: every planned speed is ``<= v_max``, so ``|p_tau - p_{t+1}|_2 <= (tau - 1) dt v_max``;
    * area: the model keeps positions in the area;
    * goal: ``|p_T - G_o|^2 <= f <= UB``, so ``|p_tau - G_o|_2 <= sqrt(UB) + (T - tau) dt v_max``;
    * growth: around the obstacle-free optimum ``u0`` (minimiser of f over the convex
      set C0 of plans without obstacle constraints) every u in C0 has
      ``f(u) - f(u0) >= (u - u0)' H (u - u0)`` (exact Taylor expansion of the quadratic f
      plus first-order optimality), ``H = g_T g_T' + rho D'D`` per axis (D the increments,
      with the link term of :class:`.model.GuidanceConfig` also ``u_0`` itself: the applied
      force is a constant).  Every plan of P1
      is in C0, so ``f <= UB`` implies ``|p_tau - p0_tau|_2 <= sigma_tau sqrt(UB - f0)``
      with ``sigma_tau^2 = g_tau' H^-1 g_tau`` (the two axes share one budget).

    The sets are boxes (force, area, a hard terminal's region) and disks; a face direction
    ``a_i`` is bounded by the tightest of their support functions (a box: centre value
    +- ``|a_x| h_x + |a_y| h_y``; a disk: centre value +- radius).  Arrays are indexed by
    tau = 0..T.
    """

    dt: float
    v_max: float
    area_lo: np.ndarray
    area_hi: np.ndarray
    sigma: np.ndarray  # growth radius per unit sqrt(cost), m / m
    free: np.ndarray  # c_tau of the zero-force response p_t + c_tau v_t, s
    force: np.ndarray  # per-axis reach under the force bound, m

    @classmethod
    def build(cls, dt, friction, mass, horizon, rho_model, v_max, force_max_model, area_lo, area_hi,
              link: bool = False) -> "Reach":
        """From the model's sensitivities (per axis; forces in model units, see :mod:`.model`)."""
        from .model import KN

        gain = dt * KN / mass
        g_p, g_v = np.zeros((horizon + 1, horizon)), np.zeros((horizon + 1, horizon))
        free_p, free_v = np.zeros(horizon + 1), np.ones(horizon + 1)
        for tau in range(1, horizon + 1):  # inherently sequential; runs once per Guidance
            g_p[tau] = g_p[tau - 1] + dt * g_v[tau - 1]
            g_v[tau] = (1.0 - friction) * g_v[tau - 1]
            g_v[tau, tau - 1] += gain
            free_p[tau] = free_p[tau - 1] + dt * free_v[tau - 1]
            free_v[tau] = (1.0 - friction) * free_v[tau - 1]
        d = np.diff(np.eye(horizon), axis=0)
        if link:
            d = np.vstack([np.eye(1, horizon), d])
        w, v = np.linalg.eigh(np.outer(g_p[-1], g_p[-1]) + rho_model * d.T @ d)
        # g' H^-1 g in H's eigenbasis; a direction H does not resolve (rho = 0, or so small
        # that H is singular to rounding) leaves p_tau unbounded there: an infinite radius
        resolved = w > w[-1] * horizon * np.finfo(float).eps
        proj = g_p @ v  # (T + 1, T)
        blind = (np.abs(proj[:, ~resolved]) > 1e-12 * np.abs(proj).max()).any(axis=1)
        sigma = np.where(blind, np.inf, np.sqrt((proj[:, resolved] ** 2 / w[resolved]).sum(axis=1)))
        return cls(dt, v_max, np.asarray(area_lo), np.asarray(area_hi), sigma, free_p, force_max_model * g_p.sum(1))

    @property
    def horizon(self) -> int:
        return len(self.sigma) - 1

    def progress(self, x0: np.ndarray, direction: np.ndarray) -> np.ndarray:
        """``(T + 1,)`` the farthest ``p_tau`` can be from ``p_0`` along ``direction (2,)``:
        the zero-force drift of the start's velocity plus the force limit's reach (per
        axis, as if the force pushed along the direction), and no more than the speed limit
        allows after the first step.  An upper bound: a path round corners makes less."""
        d = np.asarray(direction, dtype=float)
        d = d / max(np.linalg.norm(d), 1e-12)
        along = max(float(d @ x0[2:]), 0.0)
        tau = np.arange(self.horizon + 1)
        first = self.dt * np.linalg.norm(x0[2:])
        return np.minimum(self.free * along + self.force, first + np.maximum(tau - 1, 0) * self.dt * self.v_max)

    def face_bounds(self, x0, goal, normals: np.ndarray, ub=np.inf, relaxed=None, box=None) -> Bounds:
        """:class:`Bounds` of ``p_tau`` for tau = 2..T and of ``a_i . p_tau`` for the face
        ``normals (n, F, 2)``.

        ``x0 = [p_x, p_y, v_x, v_y]`` the start; ``relaxed = (points (T-1, 2), f0)`` the
        obstacle-free optimum, for the growth disk (used when ``ub`` is finite); ``box =
        (lo (2,), hi (2,))`` a hard terminal region: ``p_T`` is in it, so ``p_tau`` is
        within ``(T - tau) dt v_max`` of it.
        """
        tau = np.arange(2, self.horizon + 1)[:, None]
        free = x0[None, :2] + self.free[2:, None] * x0[None, 2:]
        boxes = [(np.maximum(self.area_lo, free - self.force[2:, None]),
                  np.minimum(self.area_hi, free + self.force[2:, None]), 0.0)]
        p1 = x0[:2] + self.dt * x0[2:]
        disks = [(p1[None, :], (tau - 1) * self.dt * self.v_max)]
        if np.isfinite(ub):
            disks.append((goal[None, :], np.sqrt(max(ub, 0.0)) + (self.horizon - tau) * self.dt * self.v_max))
            if relaxed is not None:
                points, f0 = relaxed
                budget = max(ub - f0, 0.0) * (1 + 1e-6) + 1e-6 * max(ub, 1.0)  # solver round-off
                disks.append((points, self.sigma[2:, None] * np.sqrt(budget) + 1e-3))
        if box is not None:  # the region grown by the remaining travel: a box plus a disk
            boxes.append((np.asarray(box[0])[None, :], np.asarray(box[1])[None, :],
                          (self.horizon - tau) * self.dt * self.v_max))
        lo, hi = boxes[0][0], boxes[0][1]
        for b_lo, b_hi, grow in boxes[1:]:
            lo, hi = np.maximum(lo, b_lo - grow), np.minimum(hi, b_hi + grow)
        for centre, radius in disks:
            lo, hi = np.maximum(lo, centre - radius), np.minimum(hi, centre + radius)
        f_lo, f_hi = _box_support(lo, hi, normals)
        for b_lo, b_hi, grow in boxes[1:]:
            s_lo, s_hi = _box_support(np.broadcast_to(b_lo, lo.shape), np.broadcast_to(b_hi, hi.shape), normals)
            g = np.broadcast_to(grow, (len(lo), 1))[..., None]
            f_lo, f_hi = np.maximum(f_lo, s_lo - g), np.minimum(f_hi, s_hi + g)
        for centre, radius in disks:
            c = np.einsum("rd,nfd->rnf", np.broadcast_to(centre, lo.shape), normals)
            f_lo, f_hi = np.maximum(f_lo, c - radius[..., None]), np.minimum(f_hi, c + radius[..., None])
        return Bounds(lo, hi, f_lo, f_hi)


def _box_support(lo: np.ndarray, hi: np.ndarray, normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(min, max)`` of ``a . p`` over the boxes ``[lo, hi] (T-1, 2)``: ``(T-1, n, F)`` each
    (per axis the larger or smaller of ``a_k lo_k`` and ``a_k hi_k``: exact for axis faces)."""
    at_lo = np.einsum("rd,nfd->rnfd", lo, normals)
    at_hi = np.einsum("rd,nfd->rnfd", hi, normals)
    return np.minimum(at_lo, at_hi).sum(axis=-1), np.maximum(at_lo, at_hi).sum(axis=-1)


def beyond(boxes: tuple[np.ndarray, np.ndarray], r: int, normal: np.ndarray, b: float, step: float):
    """The step boxes of :class:`Bounds` once ``p_tau`` (row ``r``) is beyond a face
    (``normal . p >= b``): row r shrinks to the bounding box of its part beyond the
    face, and the rest is closed under the speed limit (row ``r'`` keeps within
    ``|r - r'| step`` of row ``r`` per axis; ``step = v_max dt``: no point moves farther
    in one step).  None when some box empties: no plan within reach is beyond that face
    there (a branch-and-bound child that needs no QP)."""
    lo, hi = boxes[0].copy(), boxes[1].copy()
    clipped = _clip_box(lo[r], hi[r], np.asarray(normal, dtype=float), b)
    if clipped is None:
        return None
    lo[r], hi[r] = clipped
    d = np.abs(np.arange(len(lo)) - r)[:, None] * step
    lo = np.maximum(lo, lo[r] - d)
    hi = np.minimum(hi, hi[r] + d)
    return None if np.any(lo > hi + 1e-7) else (lo, hi)


def _clip_box(lo: np.ndarray, hi: np.ndarray, a: np.ndarray, b: float):
    """Bounding box ``(lo, hi)`` of ``[lo, hi] ∩ {a . p >= b}``, None if empty (within 1e-7).

    Per axis k: a point with coordinate ``p_k`` has a partner in the box beyond the face
    when ``a_k p_k + max(a_l lo_l, a_l hi_l) >= b`` (l the other axis), a bound on ``p_k``
    from below (``a_k > 0``) or above (``a_k < 0``)."""
    (x0, y0), (x1, y1), (ax, ay) = lo, hi, a
    mx, my = max(ax * x0, ax * x1), max(ay * y0, ay * y1)
    if mx + my < b - 1e-7:
        return None
    out_lo, out_hi = [x0, y0], [x1, y1]
    for k, (ak, rest) in enumerate(((ax, my), (ay, mx))):
        if ak > 0:
            out_lo[k] = min(max(out_lo[k], (b - rest) / ak), out_hi[k])
        elif ak < 0:
            out_hi[k] = max(min(out_hi[k], (b - rest) / ak), out_lo[k])
    return np.array(out_lo), np.array(out_hi)


def redundant(face_lo: np.ndarray, b: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """``(T-1, n)`` bool: (step, obstacle) pairs where every reachable point is beyond
    some face, so the obstacle cannot be hit at that step and its avoidance rows are
    redundant (a QP may leave them out; :func:`prune` fixes that face on)."""
    return ((face_lo >= b) & valid).any(axis=2)


def stuck_pairs(face_hi: np.ndarray, b: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """``(T-1, n)`` bool: (step, obstacle) pairs where no reachable point is beyond any face,
    i.e. the target cannot be out of that inflated obstacle at that step whatever it does
    (a start inside or against it)."""
    return ~((face_hi >= b) & valid).any(axis=2)


def prune(face_lo: np.ndarray, face_hi: np.ndarray, b: np.ndarray, valid: np.ndarray,
          stuck: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray] | None:
    """Fix the binaries the reachable set decides.  Returns ``(y_lo, y_hi)`` of shape
    ``(T-1, n, F)`` or None when some step has no reachable face (infeasible).

    * a face no reachable point can satisfy, or a padded face, cannot be the active one: ``y = 1``;
    * if every reachable point satisfies face i, the obstacle cannot be hit at that
      step: activate i (``y_i = 0``, a redundant constraint), switch the others off;
    * a single remaining face must be the active one (Eq. 8e);
    * ``stuck`` pairs (:func:`stuck_pairs`, decided once per solve) have every face off.
    """
    reachable = (face_hi >= b) & valid
    if stuck is not None:
        reachable = reachable & ~stuck[..., None]
    surely = (face_lo >= b) & valid
    y_lo = (~reachable).astype(float)
    y_hi = np.ones_like(y_lo)
    free = surely.any(axis=2)
    pick = np.argmax(surely, axis=2)
    onehot = np.arange(b.shape[2])[None, None, :] == pick[..., None]
    y_lo = np.where(free[..., None], (~onehot).astype(float), y_lo)
    y_hi = np.where(free[..., None], y_lo, y_hi)
    n_open = (y_lo == 0).sum(axis=2)
    if np.any((n_open == 0) & (True if stuck is None else ~stuck)):
        return None
    single = (n_open == 1)[..., None] & (y_lo == 0)
    y_hi = np.where(single, 0.0, y_hi)
    return y_lo, y_hi


def choose_faces(points: np.ndarray, faces: Faces, b: np.ndarray, y_lo: np.ndarray, y_hi: np.ndarray) -> np.ndarray:
    """A complete face choice: per step and obstacle, the allowed face with the largest
    slack ``a_i . p - b_i`` at ``points (T-1, 2)`` (the face the point is most clearly
    beyond).  Pairs with no allowed face (stuck, see :func:`prune`) stay all off.
    Returns y (T-1, n, F) in {0, 1} within the bounds."""
    slack = np.where(y_lo == 0, faces.slack(points, b), -np.inf)
    forced = y_hi == 0
    slack = np.where(forced.any(axis=2, keepdims=True), np.where(forced, np.inf, -np.inf), slack)
    pick = np.argmax(slack, axis=2)
    y = (np.arange(b.shape[2])[None, None, :] != pick[..., None]).astype(float)
    return np.where((y_lo == 1).all(axis=2, keepdims=True), 1.0, y)


def inside(points: np.ndarray, faces: Faces, b: np.ndarray) -> np.ndarray:
    """(T-1, n) how deep each point is inside each inflated obstacle (<= 0: outside).
    The largest slack is taken face by face: numpy's ``max`` along an axis of 4-8 is
    several times slower."""
    s = faces.slack(points, b)
    top = s[..., 0].copy()
    for i in range(1, s.shape[2]):
        np.maximum(top, s[..., i], out=top)
    return np.negative(top, out=top)


def binding_faces(points: np.ndarray, faces: Faces, y: np.ndarray, b: np.ndarray, tol: float = 1e-3) -> np.ndarray:
    """``(k, 3)`` indices ``(step row, obstacle, face)`` of active faces the plan touches."""
    return np.argwhere((y == 0) & (np.abs(faces.slack(points, b)) < tol))


def _runs(mask: np.ndarray) -> list[np.ndarray]:
    """Index arrays of the maximal runs of True in a 1-D mask."""
    edges = np.flatnonzero(np.diff(np.r_[0, mask.astype(int), 0]))
    return [np.arange(a, b) for a, b in zip(edges[::2], edges[1::2])]


def extend_faces(y: np.ndarray, points: np.ndarray, faces: Faces, b: np.ndarray, y_lo: np.ndarray,
                 rank: int = 0) -> np.ndarray | None:
    """One step of the upper-bound dive: switch on faces where ``points (T-1, 2)`` are
    inside an inflated obstacle.  Returns the new choice, or None if nothing is violated.

    ``y (T-1, n, F)`` may leave a step's faces all off (that step is unconstrained for
    that obstacle).  A run of consecutive violated steps gets one face for the whole run
    (a path cannot jump from one side to the opposite side in one step): the face its
    points are nearest to in total, ``sum max(0, b_i - a_i . p)`` (``rank`` 1: the
    runner-up, for an alternative dive), or, if the run touches steps already held on one
    face, that face (the detour grows).
    """
    slack = faces.slack(points, b)
    violated = np.all(slack < -1e-7, axis=2) & (y_lo == 0).any(axis=2)  # stuck pairs may be inside
    if not violated.any():
        return None
    y = y.copy()
    for j in np.flatnonzero(violated.any(axis=0)):
        held = np.argmin(y[:, j, :], axis=1)
        is_held = y[:, j, :].min(axis=1) == 0
        for run in _runs(violated[:, j]):
            near = [k for k in (run[0] - 1, run[-1] + 1) if 0 <= k < len(y) and is_held[k]]
            reach = y_lo[run, j, :] == 0  # (len(run), F): face reachable at that step
            cost = np.maximum(0.0, -slack[run, j, :]).sum(axis=0)
            ranked = np.argsort(np.where(reach.any(axis=0), cost, np.inf), kind="stable")
            face = held[near[0]] if near and reach[:, held[near[0]]].all() else ranked[min(rank, len(ranked) - 1)]
            # where that face cannot be reached (the first steps, by the force limit), take
            # the reachable face the point is nearest to: the path turns a corner there
            nearest = np.argmax(np.where(reach, slack[run, j, :], -np.inf), axis=1)
            step_face = np.where(reach[:, face], face, nearest)
            if not reach[np.arange(len(run)), step_face].all():
                return None
            y[run, j, :] = 1.0
            y[run, j, step_face] = 0.0
    return y


def tight_big_m(face_lo: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(T-1, n, F) per-step big-M: with ``y = 1`` face i must hold for every reachable
    point, ``a_i . p >= b_i - M``, so ``M = b_i - min_reach a_i . p`` suffices.  Smaller
    than the area-based M of the model, hence a tighter LP relaxation in the master.
    ``face_lo, b (T-1, n, F)``."""
    return np.maximum(b - face_lo, 0.0)
