"""Problem (P1), the guidance MIQP, as one cvxpy model built once with Parameters.

[Papaioannou2023] Sec. IV, Eq. (6)-(8).  For one target, from the start mean
``mu_t`` (Eq. 8c), choose forces ``u_{t+tau|t}``, tau = 0..T-1, to minimise Eq. (7)::

    || mu^pos_{t+T|t} - G_o ||^2 + rho sum_{tau=1}^{T-1} || u_tau - u_{tau-1} ||^2

(and, with the link term of :class:`GuidanceConfig`, ``+ rho || u_0 - u_applied ||^2``)

subject to the mean dynamics Eq. (8b), obstacle avoidance Eq. (8d)-(8e) with big-M,
and the state/input sets of Eq. (8f): ``|u_x|, |u_y| <= F``, ``u_z = 0``, ground speed
``<= v_max`` and positions inside the area.

Modelling choices (each stated where the paper is silent):

* **Ground plane.** ``u_z = 0`` leaves ``(p_z, v_z)`` uncontrolled: ``z`` follows
  ``A`` from ``mu_t`` and is ~0 for ground targets.  The model plans ``(x, y)`` only.
  The z-faces of an obstacle cannot separate a ground target (its z lies strictly
  inside the inflated z-slab ``[z_min - delta, z_max + delta]`` because ``delta > 0``),
  so only the F side faces of its prism get binaries (four for a cuboid), and an
  obstacle whose slab misses the ground band ``|z| <= GROUND_BAND_M`` is dropped.
  ``Sum_i y_i <= F - 1`` is Eq. (8e) with the z-faces removed.
* **Sparse form.** States ``x_tau = [p_x, p_y, v_x, v_y]`` are variables linked by Eq.
  (8b) written step by step; this is Eq. (6)'s closed form, unrolled.  Only the start
  state and the goal are Parameters, so a re-plan changes right-hand sides only.
* **Units.** Forces are in kN inside the model (conditioning); rho is rescaled to match,
  so the objective is Eq. (7) in m^2 exactly.
* **Speed.** ``||v||_2 <= v_max`` is replaced by an inscribed regular K-gon
  ``c_k . v <= v_max cos(pi / K)``: every vertex is on the circle, so the true speed
  never exceeds ``v_max`` (an inner approximation).
* **Safe segments.** Every face of an obstacle's footprint is pushed out by ``delta =
  v_max dt / 2 + clearance`` along its unit normal (for a cuboid: ``delta`` per axis).
  Proof that the straight segment between consecutive planned points then misses the
  original obstacle: both points lie outside the inflated one, and the segment is at most
  ``||v||_2 dt <= v_max dt`` long.  If a point q of the segment were inside the
  obstacle, the segment end nearer to q would be within ``v_max dt / 2`` of q, hence
  within ``delta`` of the footprint, so on the inner side of every pushed-out face (a
  face moves by ``delta`` along its normal, and ``a_i . (e - q) <= |e - q|``): inside the
  inflated obstacle, a contradiction.  With ``clearance > 0`` the segment keeps strictly
  clear.
* **Tight big-M.** Face i of obstacle n is ``a_i . p >= b_i + delta`` (inflated).  With
  y = 1 it must hold for every p in the area, so ``M_i = b_i + delta - min_{p in area}
  a_i . p``: the smallest valid constant, from the area bounds.
* **Step 1.** ``p_{t+1} = p_t + dt v_t`` does not depend on any control (B has no
  position rows), so its avoidance constraints cannot be influenced; they are left out
  of the model.  A start whose first step lands inside a margin is reported by the
  solver (``Plan.first_step_in_margin``) instead of making the problem infeasible.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

from ..declare import setting
from ..targets import Dynamics
from ..world import Polygons, World
from .faces import Faces

if TYPE_CHECKING:  # cvxpy is imported by build_p1 only: the fast path (uavsim.guidance.qp) never needs it
    import cvxpy as cp

    from ..world.routes import Visibility

KN = 1000.0  # model force unit: 1 kN


@dataclass(frozen=True)
class GuidanceConfig:
    """Problem (P1) settings (Eq. 7-8) and the solver's budgets.

    Attributes
    ----------
    horizon : T; rho : control-increment weight (N^-2 m^2); force_max : |u_x|, |u_y| (N);
    speed_max : ground speed (m/s); speed_sides : sides of the inscribed speed polygon;
    clearance : extra obstacle margin (m); gap : certified relative gap;
    time_limit : budget (reference s) of a first plan; replan_budget : of a re-plan (see
    :mod:`uavsim.guidance`); horizon_mode : "receding" or "shrinking" (see
    :meth:`uavsim.guidance.Guidance.horizon_at`); terminal : "soft" (P1 as published: the
    end is pulled towards the goal's centroid by Eq. (7) only) or "hard" (the plan must
    also end inside the goal region; see :meth:`uavsim.guidance.Guidance.plan`); link :
    Eq. (7) gains the term ``rho |u_{t|t} - u_{t-1}|^2``, the step from the force applied
    last (see below).

    **The link term** (``link_applied_force``, off as published).  Eq. (7) weighs the
    increments within a plan, so a re-plan may start with any force: from the very state
    a plan led to, P1 may choose another first force than that plan's next one (measured
    on towns: 18-40% of re-plans from the true state, certified optimal, missed the force
    of the plan that state came from by more than 100 N).  With the step from the applied
    force weighed as the others, the rest of a plan is optimal for the re-plan from where
    it led (Bellman's principle: the shrinking horizon keeps the plan's end, and the terms
    already past are constants), so re-plans are consistent with the plans they follow.
    A plan with no force before it (a first plan, or the first of a new horizon) links to
    zero force (:meth:`uavsim.guidance.Guidance.linked`).
    """

    horizon: int = setting("horizon", 50, lo=2, hi=300, doc="T, steps planned ahead (Eq. 7)")
    rho: float = setting("rho", 0.01, unit="m^2/N^2", lo=0, hi=1e6, doc="weight of the force increments in Eq. (7)")
    force_max: float = setting("force_max_n", 6000.0, unit="N", lo=1, hi=1e7,
                               doc="|u_x|, |u_y| limit (Eq. 8e); force_max_n / mass_kg at most 100 m/s^2")
    speed_max: float = setting("speed_max_mps", 16.0, unit="m/s", lo=0.1, hi=340,
                               doc="ground speed limit (Eq. 8f), enforced as an inscribed polygon")
    speed_sides: int = setting("speed_polygon_sides", 16, lo=4, hi=64, doc="sides of the inscribed speed polygon")
    clearance: float = setting("clearance_m", 1.0, unit="m", lo=0, hi=1000,
                               doc="obstacle margin on top of speed_max_mps x dt_s / 2")
    gap: float = setting("gap", 1e-4, lo=1e-9, hi=0.5, doc="certified relative optimality gap of a plan")
    time_limit: float = setting("time_limit_s", 10.0, unit="reference s", lo=0.01, hi=86400,
                                doc="budget of a first plan: seconds of the reference machine, counted in QPs "
                                    "(the same plan on any machine)")
    horizon_mode: str = setting("horizon_mode", "shrinking", choices=("receding", "shrinking"),
                                doc="receding: always T steps ahead; shrinking: to the first plan's end, "
                                    "then T more")
    replan_budget: float = setting("replan_budget_s", 1.0, unit="reference s", lo=0.001, hi=3600,
                                   doc="budget of a re-plan from the previous plan (reference s, as time_limit_s)")
    terminal: str = setting("terminal", "soft", choices=("soft", "hard"),
                            doc="soft: P1 as published; hard: the plan must also end inside the goal region")
    link: bool = setting("link_applied_force", False,
                         doc="also weigh the step from the force applied last, rho |u_0 - u_applied|^2 (Eq. 7 "
                             "weighs only the steps within a plan), so that a re-plan from where a plan led keeps "
                             "that plan; false: P1 as published")


@dataclass(frozen=True, eq=False)
class Geometry:
    """Numbers derived once from world, dynamics and settings.

    Attributes
    ----------
    margin : delta (m), the inflation (every footprint edge pushed out by it).
    polys : the inflated footprints of the obstacles kept (ground band), n of them, F faces
        each (padded; :class:`uavsim.world.Polygons`).
    kept : (n,) indices into ``World`` of the obstacles kept.
    faces : their faces' normals, validity and neighbours (:class:`.faces.Faces`).
    face_offsets : (n, F) inflated offsets ``b_i + delta``.
    big_m : (n, F) tight big-M per face.
    speed_dirs : (K, 2) polygon face normals; speed_bound : ``v_max cos(pi/K)``.
    """

    margin: float
    clearance: float
    polys: Polygons
    kept: np.ndarray
    faces: Faces
    face_offsets: np.ndarray
    big_m: np.ndarray
    speed_dirs: np.ndarray
    speed_bound: float
    area_lo: np.ndarray
    area_hi: np.ndarray
    names: tuple[str, ...] = ()  # of the obstacles kept, for messages

    @property
    def lo(self) -> np.ndarray:
        """(n, 2) lower corners of the inflated footprints' bounding boxes."""
        return self.polys.lo

    @property
    def hi(self) -> np.ndarray:
        return self.polys.hi

    @property
    def face_normals(self) -> np.ndarray:
        """(n, F, 2) outward unit normals."""
        return self.faces.normals

    @cached_property
    def visibility(self) -> Visibility:
        """The inflated footprints' visibility graph (:class:`uavsim.world.routes.Visibility`),
        built at the first route search and kept for every later one."""
        from ..world.routes import Visibility

        return Visibility(self.polys, self.area_lo, self.area_hi)


def geometry(world: World, dynamics: Dynamics, cfg: GuidanceConfig) -> Geometry:
    """Inflated obstacles, tight big-M and the speed polygon (see module docstring)."""
    margin = cfg.speed_max * dynamics.dt / 2.0 + cfg.clearance
    kept, polys = world.ground(margin)
    a_lo, a_hi = world.area_lo[:2], world.area_hi[:2]
    # min over the area of a_i . p, per axis the smaller of a_k lo_k and a_k hi_k
    area_min = np.minimum(polys.normals * a_lo, polys.normals * a_hi).sum(axis=-1)
    k = cfg.speed_sides
    ang = 2.0 * np.pi * (np.arange(k) + 0.5) / k
    return Geometry(
        margin=margin, clearance=cfg.clearance, polys=polys, kept=kept,
        faces=Faces(polys.normals, polys.valid, polys.neighbours()),
        face_offsets=polys.offsets, big_m=polys.offsets - area_min,
        speed_dirs=np.column_stack([np.cos(ang), np.sin(ang)]),
        speed_bound=cfg.speed_max * np.cos(np.pi / k), area_lo=a_lo, area_hi=a_hi,
        names=tuple(world.obstacle_names[i] for i in kept),
    )


@dataclass(frozen=True, eq=False)
class P1:
    """The cvxpy model of Problem (P1) for one target, with its handles.

    Variables: ``x (T+1, 4)`` states, ``u (T, 2)`` forces (kN), ``e (2,)`` terminal
    error, ``d (T-1, 2)`` control increments (kN), ``y (T-1, F n)`` face binaries
    (paper convention: ``y = 1`` switches a face off; column ``F j + i`` is face i of
    kept obstacle j; row r is planned step ``tau = r + 2``).
    Parameters: ``x0 (4,)`` start ``[p_x, p_y, v_x, v_y]``, ``goal (2,)``, with a hard
    terminal ``box (4,)`` the goal region ``[x_min, y_min, x_max, y_max]`` (else None),
    and with the link term ``applied (2,)`` the force applied last (kN; its variable
    ``link = u_0 - applied``; else both None).
    """

    problem: cp.Problem
    x: cp.Variable
    u: cp.Variable
    e: cp.Variable
    d: cp.Variable
    y: cp.Variable | cp.Parameter
    x0: cp.Parameter
    goal: cp.Parameter
    rho_model: float  # rho in the model's units: rho * KN^2
    geom: Geometry
    horizon: int
    box: cp.Parameter | None = None
    applied: cp.Parameter | None = None
    link: cp.Variable | None = None


def build_p1(world: World, dynamics: Dynamics, cfg: GuidanceConfig, fixed_faces: bool = False) -> P1:
    """Build Problem (P1) once; re-plans only set ``x0`` and ``goal``.

    With ``fixed_faces`` the binaries are a Parameter instead of a Variable: the convex
    QP "P1 with the face choice fixed" (the outer approximation's upper-bound problem).

    References
    ----------
    [Papaioannou2023] Eq. (7)-(8).
    """
    import cvxpy as cp

    geom = geometry(world, dynamics, cfg)
    t, n = cfg.horizon, len(geom.kept)
    dt, keep_v, gain = dynamics.dt, 1.0 - dynamics.friction, dynamics.dt * KN / dynamics.mass
    x = cp.Variable((t + 1, 4), name="x")
    u = cp.Variable((t, 2), name="u")
    e = cp.Variable(2, name="e")
    d = cp.Variable((t - 1, 2), name="d")
    f = geom.polys.width
    shape = (t - 1, max(f * n, 1))
    # without obstacles there are no binaries: y is an unused Parameter and P1 is a QP
    y = cp.Parameter(shape, name="y") if fixed_faces or not n else cp.Variable(shape, boolean=True, name="y")
    x0 = cp.Parameter(4, name="x0")
    goal = cp.Parameter(2, name="goal")
    pos, vel = x[:, :2], x[:, 2:]
    f_max = cfg.force_max / KN
    cons = [
        x[0] == x0,  # Eq. (8c)
        pos[1:] == pos[:-1] + dt * vel[:-1],  # Eq. (8b), position rows of A
        vel[1:] == keep_v * vel[:-1] + gain * u,  # Eq. (8b), velocity rows of A and B
        e == pos[t] - goal,
        d == u[1:] - u[:-1],
        u <= f_max,
        u >= -f_max,  # two one-sided bounds: |u| <= F written as cp.abs confuses HiGHS QP
        vel[1:] @ geom.speed_dirs.T <= geom.speed_bound,
        pos[2:] >= geom.area_lo,
        pos[2:] <= geom.area_hi,
    ]
    if n:
        # a_i . p for the F faces of every kept obstacle, steps 2..T: (T-1, F n)
        lhs = pos[2:] @ geom.face_normals.reshape(-1, 2).T
        per_obstacle = np.kron(np.eye(n), np.ones((f, 1)))  # (F n, n): sums each obstacle's faces
        cons += [
            lhs >= geom.face_offsets.reshape(-1) - cp.multiply(geom.big_m.reshape(-1), y),  # Eq. (8d)
        ]
        if not fixed_faces:
            cons.append(y @ per_obstacle <= f - 1)  # Eq. (8e)
    box = cp.Parameter(4, name="box") if cfg.terminal == "hard" else None
    if box is not None:
        cons += [pos[t] >= box[:2], pos[t] <= box[2:]]
    rho_model = cfg.rho * KN**2
    cost = cp.sum_squares(e) + rho_model * cp.sum_squares(d)
    applied = link = None
    if cfg.link:
        applied, link = cp.Parameter(2, name="applied"), cp.Variable(2, name="link")
        cons.append(link == u[0] - applied)
        cost = cost + rho_model * cp.sum_squares(link)
    problem = cp.Problem(cp.Minimize(cost), cons)
    return P1(problem, x, u, e, d, y, x0, goal, rho_model, geom, t, box, applied, link)
