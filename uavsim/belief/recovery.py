"""A lost track re-seeded from the bearings and the routes.

When a target's particle cloud no longer explains its bearings
(:attr:`.particle.ParticleBelief.lost`), the closed loop (:mod:`uavsim.sim`) replaces a
share of its particles (``[filter] reseed_share``) by draws of where the latest scans say
the target may be ("sensor resetting", [Lenser2000]):

* **position**: a measured bearing, picked uniformly among the step's valid ones (the
  target's own with probability about ``p_D / (p_D + L)``, clutter otherwise: later scans
  weigh them), plus N(0, sigma^2) noise, and a range uniform along that ray where the
  target can be: inside the area and within its reach from the prior (:func:`reach`),
  outside every obstacle;
* **velocity**: the speed of a particle of the old cloud, along the shortest free route
  to the target's goal from the new position (:class:`uavsim.world.routes.GoalField`,
  its gradient by central differences at 32 of the positions, each draw taking its
  nearest's): a guided target follows a route to its goal, not the heading of a cloud on
  the wrong street;
* **height and vertical velocity**: those of the same old particle (ground targets).

The draws are a proposal, not a posterior: every particle then weighs ``1 / N``
(:meth:`.particle.ParticleBelief.reseed`) and the next scans sort the rays' wrong ranges
and the clutter bearings out.  Nothing loops over particles.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..sensing import BearingModel, Scan
from ..world.model import World

if TYPE_CHECKING:  # the routes bring scipy and shapely, which reading a mission does not need
    from ..world.routes import GoalField

REACH_SIGMAS = 4.0  # prior and process-noise standard deviations a target's reach allows (reach)
ROUTE_POINTS = 32  # positions per target where the route's direction is computed
ROUTE_STEP_M = 1.0  # central-difference step of the route length's gradient
REDRAWS = 8  # rounds of redrawing a range that falls in an obstacle


def reach(mean0: np.ndarray, cov0: np.ndarray, steps: int, dt: float, speed_max: float,
          q: np.ndarray | None = None) -> np.ndarray:
    """``(M,)`` radii (m) of the discs about the prior means ``mean0 (M, 6)`` that hold the
    targets after ``steps`` steps of Eq. (2): a start within :data:`REACH_SIGMAS` of
    ``N(mu_0, Sigma_0)`` (``cov0 (M, 6, 6)``, its largest horizontal standard deviations),
    the first step at the drawn velocity, every later one at most ``speed_max`` (the guidance
    keeps the planned velocities in its inscribed speed polygon, Eq. (8)) and, with the
    process noise ``q (6, 6)`` of a stochastic truth, the sum of its steps' noise within as
    many of that sum's standard deviations: each step's position noise, and its velocity
    noise carried for the steps that remain (friction left out, which only shrinks it),
    ``sd^2 = steps s_p^2 + s_v^2 dt^2 sum_{k=1}^{steps} (steps - k)^2``.  A target
    outside its disc is one the model says cannot be there."""
    def sd(c, axes):
        return np.sqrt(np.linalg.eigvalsh(c[..., axes, :][..., :, axes])[..., -1])

    pos, vel = [0, 1], [3, 4]
    r = REACH_SIGMAS * sd(cov0, pos) + (np.hypot(*mean0[:, vel].T) + REACH_SIGMAS * sd(cov0, vel)) * dt
    r = r + max(steps - 1, 0) * speed_max * dt
    if q is not None:
        carried = (steps - 1) * steps * (2 * steps - 1) / 6  # sum over k = 1..steps of (steps - k)^2
        r = r + REACH_SIGMAS * np.sqrt(steps * sd(q, pos) ** 2 + carried * (sd(q, vel) * dt) ** 2)
    return r


def draw(rng: np.random.Generator, cloud: np.ndarray, scans: list[Scan], observers: np.ndarray, sensor: BearingModel,
         world: World, fields: list[GoalField | None], rows: np.ndarray, n: int,
         discs: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(fresh (L, n, 6), ok (L,))``: n draws for each lost target ``rows (L,)`` from its
    old particles ``cloud (L, N, 6)`` and the step's ``scans`` taken at ``observers (S, 3)``
    (module docstring); ``fields[l]``: the route field to row l's goal (None: straight to
    nothing, the old velocities are kept); ``discs``: centres ``(L, 2)`` and radii ``(L,)``
    of where each can be (:func:`reach`; None: anywhere in the area).  ``ok`` is False where
    the step has no valid bearing of that target or no ray crosses free ground within its
    disc: those keep their cloud."""
    bearings = np.concatenate([s.bearings[rows] for s in scans], axis=1)  # (L, S K)
    valid = np.concatenate([s.valid[rows] for s in scans], axis=1)
    origin = np.concatenate([np.broadcast_to(o[:2], (s.valid.shape[1], 2)) for s, o in zip(scans, observers)])
    ok = valid.any(axis=1)
    pick = _uniform_valid(rng, valid, n)  # (L, n) columns
    phi = np.take_along_axis(bearings, pick, axis=1) + sensor.sigma * rng.standard_normal(pick.shape)
    u = np.stack([np.sin(phi), np.cos(phi)], axis=-1)  # (L, n, 2): Eq. (4) bearings, north, clockwise
    o = origin[pick]  # (L, n, 2)
    old = cloud[np.arange(len(rows))[:, None], rng.integers(cloud.shape[1], size=pick.shape)]  # (L, n, 6)
    t0, t1 = _ray_in_box(o, u, world.area_lo[:2], world.area_hi[:2])
    if discs is not None:
        c0, c1 = _ray_in_disc(o, u, discs[0][:, None, :], discs[1][:, None])
        t0, t1 = np.maximum(t0, c0), np.minimum(t1, c1)
    xyz = old[..., :3].copy()
    todo = t1 > t0
    for _ in range(REDRAWS):
        r = t0 + rng.random(t0.shape) * np.maximum(t1 - t0, 0.0)
        p = o + r[..., None] * u
        xyz[..., :2] = np.where(todo[..., None], p, xyz[..., :2])
        todo &= world.in_obstacle(world.on_ground(xyz))
        if not todo.any():
            break
    placed = (t1 > t0) & ~todo  # else the old particle stays as it was
    ok &= placed.any(axis=1)
    fresh = old.copy()
    fresh[..., :2] = np.where(placed[..., None], xyz[..., :2], old[..., :2])
    speed = np.hypot(old[..., 3], old[..., 4])
    for i, field in enumerate(fields):
        if field is not None and placed[i].any():
            heading = _route_heading(rng, field, fresh[i, :, :2])
            fresh[i, :, 3:5] = np.where(placed[i, :, None], speed[i, :, None] * heading, old[i, :, 3:5])
    return fresh, ok


def _uniform_valid(rng: np.random.Generator, valid: np.ndarray, n: int) -> np.ndarray:
    """``(L, n)`` column indices drawn uniformly among each row's valid entries of ``valid
    (L, K)`` (0 for a row with none)."""
    cum = np.cumsum(valid, axis=1)  # (L, K)
    target = np.floor(rng.random((len(valid), n)) * cum[:, -1:]).astype(int)  # 0 .. count - 1
    return np.minimum((cum[:, None, :] <= target[..., None]).sum(axis=-1), valid.shape[1] - 1)


def _ray_in_box(o: np.ndarray, u: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(t0, t1)``, each ``(...)``: the part ``o + t u, t0 <= t <= t1, t >= 0`` of each ray
    ``o (..., 2)``, ``u (..., 2)`` inside the box ``[lo, hi]`` (slabs; ``t1 <= t0``: none)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        a, b = (lo - o) / u, (hi - o) / u
    a = np.where(u == 0, np.where((o >= lo) & (o <= hi), -np.inf, np.inf), a)
    b = np.where(u == 0, np.where((o >= lo) & (o <= hi), np.inf, -np.inf), b)
    t0 = np.maximum(np.minimum(a, b).max(axis=-1), 0.0)
    t1 = np.maximum(a, b).min(axis=-1)
    return t0, t1


def _ray_in_disc(o: np.ndarray, u: np.ndarray, c: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(t0, t1)``, each ``(...)``: the part ``o + t u, t0 <= t <= t1`` of each ray ``o
    (..., 2)``, unit ``u (..., 2)`` inside the disc of centre ``c (..., 2)`` and radius ``r
    (...)`` (``t1 < t0``: none)."""
    along = ((c - o) * u).sum(axis=-1)
    half = r**2 - ((c - o) ** 2).sum(axis=-1) + along**2
    root = np.sqrt(np.maximum(half, 0.0))
    return np.where(half >= 0, along - root, np.inf), np.where(half >= 0, along + root, -np.inf)


def _route_heading(rng: np.random.Generator, field: GoalField, points: np.ndarray) -> np.ndarray:
    """``(n, 2)`` unit directions of the shortest free route to the field's goal at
    ``points (n, 2)``: minus the route length's gradient at :data:`ROUTE_POINTS` of them,
    each point taking its nearest's; straight at the goal where no route is found."""
    probe = points[rng.choice(len(points), size=min(ROUTE_POINTS, len(points)), replace=False)]
    e = ROUTE_STEP_M * np.eye(2)
    offsets = np.concatenate([probe + e[0], probe - e[0], probe + e[1], probe - e[1]])
    length = field.lengths(offsets).reshape(4, -1)
    grad = np.stack([length[0] - length[1], length[2] - length[3]], axis=-1)  # (P, 2), 2 step units
    straight = field.nodes[0] - probe
    good = np.isfinite(grad).all(axis=1) & (np.abs(grad).sum(axis=1) > 0)
    head = np.where(good[:, None], -np.nan_to_num(grad, posinf=0.0, neginf=0.0), straight)
    head /= np.maximum(np.linalg.norm(head, axis=1, keepdims=True), 1e-12)
    nearest = np.argmin(((points[:, None, :] - probe[None]) ** 2).sum(-1), axis=1)
    return head[nearest]
