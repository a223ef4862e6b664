"""Target guidance: Problem (P1) of [Papaioannou2023] Sec. IV, solved exactly
where the budget allows and always with a certified gap.

``Guidance`` assembles P1's matrices once per horizon length (:mod:`.compiled`) and
solves them by QP branch-and-bound and outer approximation with HiGHS (:mod:`.oa`), or
the cvxpy model (:mod:`.model`) with SCIP for cross-checks.  ``Guidance.plan`` returns
a :class:`Plan`.

**Budgets.**  A first plan (no previous plan to start from) may spend
``time_limit_s``; a re-plan ``replan_budget_s``.  Both are seconds of the reference
machine (the 2-core Intel Xeon of docs/data/budget.json): each fixed-face QP is charged what it costs
there, from what it did (its DAQP calls, rows and iterations, its Clarabel solves:
:data:`.qp.WORK_CALL_S` and the rest) and the search's work round it
(:data:`.oa.NODE_SECONDS`), not from the clock, so a plan depends on its inputs only:
campaigns stay bit-identical on any machine and for any number of workers.  On the
reference machine a budget of 10 s took about 10 s when the constants were fitted, and
0.6-0.9 of that on re-plans since the QPs' overhead shrank (``benchmarks/budget.py``
measures the ratio of wall to reference seconds).
Within its budget a solve returns the best collision-free plan it has, with its
certified gap (status "feasible" when above the tolerance); one that has no plan yet goes
on looking up to :data:`NEED_FACTOR` times its budget plus one second, still counted in
work.  The work the solver does not count (the route search of a first plan, the
reachable sets) grows with the obstacles: on a 400-building town a budget lasts 2.3-2.8
times its seconds.  A wall-clock cap of :data:`WALL_CAP` times what the solve may spend
stops only a solve that runs far slower than that; the plan then says so.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from ..targets import HORIZONTAL, Dynamics
from ..world import GROUND_BAND_M, World
from .faces import Reach
from .model import KN, GuidanceConfig, geometry

if TYPE_CHECKING:
    from .oa import Budget

# The solvers (.compiled, .oa, .qp: HiGHS, DAQP, Clarabel, scipy.linalg) are imported by
# the methods that use them, and cvxpy by the SCIP path only: reading a mission imports
# this package (for GuidanceConfig) and must stay light (tests/test_layout.py).

SOLVERS = {  # name -> what it is (`uavsim plan --solver`'s help)
    "highs": "exact, with a certified gap: branch-and-bound over the obstacle faces, each node a QP (DAQP, "
             "Clarabel as fallback), HiGHS for the outer-approximation master",
    "scip": "SCIP through cvxpy (pip install 'uavsim[scip]'), for cross-checks",
}
DEFAULT_SOLVER = "highs"
NEED_FACTOR = 4.0  # a solve with no plan yet may spend this many times its budget, plus one reference second
WALL_CAP = 5.0  # the wall clock stops a solve at this many times those reference seconds (a safety net)
SENSITIVITY_STEP = np.array([1e-3, 1e-3, 1e-4, 1e-4])  # m, m, m/s, m/s (Guidance.sensitivity)


@dataclass(frozen=True, eq=False)
class Plan:
    """One target's guidance plan over the horizon (SI units).

    Attributes
    ----------
    status : "optimal" (certified gap <= tolerance), "feasible" (collision-free, within the
        limits, gap above the tolerance: the budget ran out), "infeasible", "error" or
        "fallback" (the caller reused the previous plan shifted by one step; see
        :meth:`shifted`).
    objective : Eq. (7) in m^2; lower_bound : certified; gap : ``(obj - lb) / max(obj, 1)``.
    iterations : master MILPs solved; solve_seconds : wall time; work_seconds : the
    budget's reference seconds spent (:mod:`uavsim.guidance`, Budgets).
    controls : (T, 3) N, ``u_{t+tau|t}``; means : (T, 6) ``mu_{t+tau+1|t}`` (Eq. 6, 8b);
    covs : (T, 6, 6) ``Sigma_{t+tau+1|t}`` (Eq. 6).
    faces : (T-1, n, F) active-face choice (warm start); terms : (K,) squared terms.
    first_step_in_margin : ``mu_{t+1|t}``, fixed by the start, lies inside an obstacle's
        safety margin (its avoidance constraint cannot be enforced; see model docstring).
    moved_start : no plan started from the belief's mean; this one starts from a nearby
        start within the limits (:meth:`Guidance.replan`; the message says which).
    unreachable : a hard terminal was asked for (``GuidanceConfig.terminal``) and no plan
        ending in the goal region was found (proved impossible, or none within the
        budget; the message says which); this plan is P1's with the soft terminal term.
    guarded_from : the first planned step from which every avoidance constraint holds: 2
        (step 1 is fixed by the start), later where the start lies in an obstacle's margin
        and cannot leave it sooner (the message names the obstacles).
    start : (6,) the mean the plan starts from (None if it has no controls).
    capped : the wall-clock cap (:data:`WALL_CAP`), not the work budget, stopped the solve:
        the plan may differ on another machine or under another load (the solver's message
        says so; :attr:`Guidance.capped` counts such solves).  A fallback after a capped solve is capped.
    """

    status: str
    objective: float
    lower_bound: float
    gap: float
    iterations: int
    solve_seconds: float
    controls: np.ndarray | None
    means: np.ndarray | None
    covs: np.ndarray | None
    faces: np.ndarray | None = None
    terms: np.ndarray | None = None
    first_step_in_margin: bool = False
    message: str = ""
    moved_start: bool = False
    unreachable: bool = False
    work_seconds: float = 0.0
    guarded_from: int = 2
    start: np.ndarray | None = None
    capped: bool = False

    @property
    def eventful(self) -> bool:
        """A fallback, a plan from a moved start, a soft plan where a hard terminal was
        asked for, or avoidance dropped at early steps: the closed loop logs its message."""
        return self.status == "fallback" or self.moved_start or self.unreachable or self.guarded_from > 2

    @property
    def ok(self) -> bool:
        return self.controls is not None

    @property
    def positions(self) -> np.ndarray:
        return self.means[:, :3]

    def shifted(self, dynamics: Dynamics, mean: np.ndarray, cov: np.ndarray, why: str, by: int = 1) -> "Plan":
        """The fallback after a failed re-plan: this plan's controls ``by`` steps on (the
        last repeated), propagated from the new start ``N(mean, cov)`` with Eq. (6)."""
        controls = np.vstack([self.controls[by:], np.repeat(self.controls[-1:], by, axis=0)])
        means, covs = dynamics.predict_moments(mean, cov, controls)
        faces = None if self.faces is None else np.concatenate([self.faces[by:], np.repeat(self.faces[-1:], by, 0)])
        return replace(self, status="fallback", controls=controls, means=means, covs=covs, faces=faces,
                       solve_seconds=0.0, iterations=0, message=why, start=np.array(mean, float))


class Guidance:
    """Problem (P1) for one world, dynamics and settings: each horizon length's program is
    assembled once (lazily; ~2 ms), then re-solved with new parameters.

    ``plan`` is a pure function of its arguments (no state carries over between calls),
    so plans are reproducible whatever order targets or trials are solved in.
    """

    def __init__(self, world: World, dynamics: Dynamics, cfg: GuidanceConfig, solver: str = DEFAULT_SOLVER):
        if solver not in SOLVERS:
            raise ValueError(f"unknown guidance solver {solver!r}; choose from {', '.join(SOLVERS)}")
        self.world, self.dynamics, self.cfg, self.solver = world, dynamics, cfg, solver
        self.geom = geometry(world, dynamics, cfg)
        self._models: dict[int, tuple] = {}
        self._cold: dict[bytes, Plan] = {}  # plans without warm start: a pure function of the inputs unless capped
        self.capped = 0  # solves the wall-clock cap stopped (Plan.capped), a cached cold plan at each reuse
        self.kept: dict = {}  # what a closed loop derives from this guidance alone, the same every trial
        self.reach, self.oa = self._model(cfg.horizon)

    def _model(self, horizon: int):
        """``(reach, oa)`` for a horizon length (``oa`` is the cvxpy model for SCIP)."""
        if horizon not in self._models:
            dyn, g, rho = self.dynamics, self.geom, self.cfg.rho * KN**2
            reach = Reach.build(dyn.dt, dyn.friction, dyn.mass, horizon, rho, self.cfg.speed_max,
                                self.cfg.force_max / KN, g.area_lo, g.area_hi, self.cfg.link)
            if self.solver == "scip":
                from .model import build_p1

                oa = build_p1(self.world, dyn, replace(self.cfg, horizon=horizon))
            else:
                from .compiled import assemble_p1
                from .oa import OuterApproximation

                c = assemble_p1(g, dyn.dt, dyn.friction, dyn.mass, horizon, rho, self.cfg.force_max / KN,
                                self.cfg.link)
                oa = OuterApproximation(c, g, reach, self.cfg.gap)
            self._models[horizon] = (reach, oa)
        return self._models[horizon]

    @staticmethod
    def budget(seconds: float, master: bool) -> Budget:
        """A :class:`Budget` of ``seconds`` of the reference machine (counted in QPs by the
        solver), ``NEED_FACTOR * seconds + 1`` of them while it has no plan, and a wall-clock
        deadline :data:`WALL_CAP` times that."""
        from .oa import Budget

        need = NEED_FACTOR * seconds + 1.0
        return Budget(seconds, time.perf_counter() + WALL_CAP * need, master, need=need)

    def horizon_at(self, step: int) -> int:
        """Horizon of the re-plan at mission step ``step`` (0 = the first plan).

        ``receding``: always T.  ``shrinking``: the plan of step 0 ends at step T, and each
        re-plan keeps that end (``T - step mod T``, at least 2); a new T-step plan starts
        every T steps.
        """
        t = self.cfg.horizon
        return t if self.cfg.horizon_mode == "receding" else max(2, t - step % t)

    def plan(self, mean: np.ndarray, cov: np.ndarray, goal: np.ndarray, warm: Plan | None = None,
             step: int = 0, shift: int = 1, applied: np.ndarray | None = None) -> Plan:
        """Solve P1 from the belief ``N(mean (6,), cov (6, 6))`` (Eq. 8c) to ``goal (3,)``.

        ``warm``: a plan made ``shift`` steps earlier (1: the previous step's plan of this
        target; 0: a plan of this step from a nearby start), whose faces and terms, shifted
        by ``shift`` steps, start the search; with it the solve spends ``replan_budget_s``,
        without it ``time_limit_s``.
        ``step``: the mission step the plan starts at, which sets its horizon
        (:meth:`horizon_at`).  ``applied (3,)``: the force (N) the target applied the step
        before, which the link term weighs the first force against (read only with
        ``link_applied_force``; see :meth:`linked`).

        With ``terminal = "hard"`` the plan must end inside the goal region whose centroid
        is ``goal`` (ValueError if the world has none); where no such plan is found, the
        same budget again solves P1 as published and the plan says so
        (:attr:`Plan.unreachable`).
        """
        from .qp import SolverError

        t0 = time.perf_counter()
        horizon = self.horizon_at(step)
        link = self.linked(applied, step)
        key = None
        if warm is None:  # e.g. every trial's filter plans from the prior: the same inputs, the same plan
            key = np.r_[mean, cov.ravel(), goal, horizon, link].tobytes()
            if key in self._cold:
                self.capped += self._cold[key].capped  # every reuse carries the cap into its trial
                return self._cold[key]
        try:
            plan = self._plan(mean, cov, goal, None if warm is None else (warm, shift), horizon, t0, link)
        except SolverError as exc:  # both QP solvers failed: an outcome the caller handles (replan)
            return self._failed("error", t0, str(exc))
        if key is not None:
            if len(self._cold) >= 256:
                self._cold.pop(next(iter(self._cold)))
            self._cold[key] = plan
        self.capped += plan.capped
        return plan

    def linked(self, applied: np.ndarray | None, step: int) -> np.ndarray:
        """``(2,)`` the force (kN) the link term of a plan at ``step`` weighs its first force
        against: ``applied``; zero without ``link_applied_force`` (nothing reads it) and where
        no force comes before the plan (``applied`` None, or the first plan of a new
        shrinking horizon, which starts afresh as the first plan did).

        Zero, not the force that would hold the start's velocity against friction: that one
        grows with the velocity, which a filter knows least at the start; every particle
        of a half moves by one plan's force, so a force proportional to each particle's
        own velocity would fit none of them (in an exploratory run, 3 trials on a Helsinki
        crop, the filter's forces missed the truth's by a median of 1 040 N with that
        force, 331 N with zero)."""
        fresh = applied is None or (self.cfg.horizon_mode == "shrinking" and step % self.cfg.horizon == 0)
        if not self.cfg.link or fresh:
            return np.zeros(2)
        return np.asarray(applied, float)[:2] / KN

    def sensitivity(self, start: np.ndarray, goal: np.ndarray, plan: Plan, step: int = 0) -> tuple[np.ndarray, bool]:
        """``(G (T, 4, 4), smooth)``: d ``plan.means`` / d ``start`` on [x, y, vx, vy] of a
        noise-free plan from ``start (6,)``, by central differences of ``SENSITIVITY_STEP``.

        P1's optimum is piecewise affine in the start (a QP for each face choice and active
        set), so near ``start`` it is the QP with ``plan.faces`` fixed: each difference
        re-solves that one QP (:meth:`.oa.OuterApproximation.with_faces`), not P1, and is
        exact unless the active set changes within the step; ``smooth`` is False when the
        forward and backward differences disagree (then G is their mean).  Where that QP
        has no plan from a moved start (or the solver is SCIP), P1 is solved anew.  Used for
        the accuracy floor of a planned truth (:mod:`uavsim.bounds.pcrlb`), whose plans
        start afresh (with the link term, from zero force: :meth:`linked`).

        Raises
        ------
        RuntimeError when no plan exists from a start moved by the step.
        """
        cols, smooth = [], True
        for i, d in zip(HORIZONTAL, SENSITIVITY_STEP):
            e = np.zeros(6)
            e[i] = d
            ends = [self._branch_means(start + s * e, goal, plan, step) for s in (1, -1)]
            if any(m is None for m in ends):
                raise RuntimeError(f"no plan from the start moved by {d:g} along state component {i}")
            fwd, bwd = (s * (m[:, HORIZONTAL] - plan.means[:, HORIZONTAL]) / d for s, m in zip((1, -1), ends))
            smooth &= bool(np.allclose(fwd, bwd, rtol=1e-4, atol=1e-4))
            cols.append((fwd + bwd) / 2)
        return np.stack(cols, axis=-1), smooth

    def gains(self, start: np.ndarray, goal: np.ndarray, plan: Plan, step: int = 0) -> tuple[np.ndarray, bool]:
        """``(K (T, 3, 4), smooth)``: d ``plan.controls`` / d ``start`` on [x, y, vx, vy], the
        force a plan from a start moved by ``d`` changes by, ``K_t d`` (:meth:`sensitivity`;
        zero along z).  With ``G_t = d x_{t+1} / d x_0`` and Eq. (1) on the ground,
        ``G_t = A G_{t-1} + B K_t`` (``G_{-1} = I``), so ``K_t = B^+ (G_t - A G_{t-1})``
        (the plan's means follow Eq. (1), so the difference lies in B's range, and B has full
        column rank).

        Raises
        ------
        RuntimeError when no plan exists from a start moved by the sensitivity's step.
        """
        g, smooth = self.sensitivity(start, goal, plan, step)
        a = self.dynamics.a[np.ix_(HORIZONTAL, HORIZONTAL)]
        b = self.dynamics.b[HORIZONTAL, :2]
        before = np.concatenate([np.eye(4)[None], g[:-1]])  # G_{t-1}
        k = np.linalg.pinv(b) @ (g - a @ before)  # (T, 2, 4)
        return np.concatenate([k, np.zeros((len(g), 1, 4))], axis=1), smooth

    def _branch_means(self, start: np.ndarray, goal: np.ndarray, plan: Plan, step: int) -> np.ndarray | None:
        """``(T, 6)`` the means of P1's plan from ``start`` on ``plan``'s face choice (see
        :meth:`sensitivity`), None if there is none."""
        zero = np.zeros((6, 6))
        if self.solver != "scip" and plan.faces is not None:
            _, oa = self._model(len(plan.controls))
            box = self._region(goal) if self.cfg.terminal == "hard" and not plan.unreachable else None
            sol = oa.with_faces(start[[0, 1, 3, 4]], goal[:2], plan.faces, box, self.linked(None, step))
            if sol is not None:
                controls = np.column_stack([sol.u * KN, np.zeros(len(sol.u))])
                return self.dynamics.predict_moments(start, zero, controls)[0]
        again = self.plan(start, zero, goal, step=step)
        return again.means if again.ok else None

    def replan(self, mean: np.ndarray, cov: np.ndarray, goal: np.ndarray, previous: Plan | None,
               step: int, shift: int = 1, applied: np.ndarray | None = None) -> Plan:
        """The closed loop's plan, which always exists: a new plan (:meth:`plan`); if none is
        found, a plan from the nearest start within the area and speed limit if the estimate
        is outside them (:meth:`_within_limits`), then from that position at rest (an
        estimate near the area's edge can head out faster than the force limit can turn;
        at rest, zero force is a plan); the message says which.  Failing those, ``previous``
        one step on (:meth:`Plan.shifted`); without a previous plan, zero force over the
        horizon.  The last two have status "fallback" and say why.  ``shift``: how many
        steps before ``step`` ``previous`` was made; ``applied``: the force applied last
        (:meth:`plan`)."""
        plan = self.plan(mean, cov, goal, warm=previous, step=step, shift=shift, applied=applied)
        if plan.ok:
            return plan
        inside, why = self._within_limits(mean)
        tries = [(inside, f"planned from the nearest start within the limits ({why})")] if why else []
        if np.any(inside[3:5]):
            where = f"({inside[0]:.1f}, {inside[1]:.1f}) m" if why else "the estimate"
            tries.append((np.r_[inside[:3], 0.0, 0.0, inside[5]], f"no plan from the estimated velocity "
                          f"({mean[3]:.1f}, {mean[4]:.1f}) m/s; planned from rest at {where}"))
        for start, how in tries:
            retry = self.plan(start, cov, goal, warm=previous, step=step, shift=shift, applied=applied)
            if retry.ok:
                return replace(retry, message="; ".join(filter(None, [how, retry.message])), moved_start=True,
                               capped=retry.capped or plan.capped)
        if previous is not None:
            flown = previous.shifted(self.dynamics, mean, cov, f"re-plan {plan.status} ({plan.message}); "
                                                             "flying the previous plan", shift)
            return replace(flown, capped=plan.capped)
        controls = np.zeros((self.horizon_at(step), 3))
        means, covs = self.dynamics.predict_moments(mean, cov, controls)
        return replace(plan, status="fallback", controls=controls, means=means, covs=covs, start=np.array(mean, float),
                       message=f"no plan ({plan.status}: {plan.message}); coasting")

    def _plan(self, mean, cov, goal, warm, horizon, t0, link) -> Plan:
        if self.cfg.terminal == "soft":
            return self._solve(mean, cov, goal, warm, horizon, t0, link)
        plan = self._solve(mean, cov, goal, warm, horizon, t0, link, self._region(goal))
        if plan.ok:
            return plan
        soft = self._solve(mean, cov, goal, warm, horizon, time.perf_counter(), link)
        if not soft.ok:
            return soft
        why = "goal region unreachable within the horizon" if plan.status == "infeasible" else "no plan found"
        return replace(soft, unreachable=True, solve_seconds=time.perf_counter() - t0,
                       work_seconds=plan.work_seconds + soft.work_seconds, capped=plan.capped or soft.capped,
                       message="; ".join(filter(None, [f"{why} ({plan.message}): soft terminal", soft.message])))

    def _region(self, goal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(lo (2,), hi (2,))`` of the world's goal region with centroid ``goal``."""
        for g in self.world.goals:
            if np.allclose(g.centroid[:2], goal[:2], rtol=0, atol=1e-9):
                return g.lo, g.hi
        raise ValueError(f"terminal = 'hard' needs a goal region; none has its centroid at {goal[:2].tolist()}")

    def _solve(self, mean, cov, goal, warm, horizon, t0, link, box=None) -> Plan:
        _, oa = self._model(horizon)
        x0 = np.array([mean[0], mean[1], mean[3], mean[4]])
        z_means, _ = self.dynamics.predict_moments(mean, cov, np.zeros((horizon, 3)))
        if np.any(np.abs(z_means[:, 2]) > GROUND_BAND_M):
            why = f"target is not on the ground (|z| > {GROUND_BAND_M} m within the horizon)"
            return self._failed("error", t0, why)
        work, guarded, capped = 0.0, 2, False
        if self.solver == "scip":
            status, obj, lb, u, faces, terms, it, msg = self._solve_scip(oa, x0, goal[:2], box, link)
        else:
            shifted = None if warm is None or warm[0].faces is None else _shift_warm(*warm, horizon)
            seconds = self.cfg.time_limit if warm is None else self.cfg.replan_budget
            budget = self.budget(seconds, master=warm is None)
            sol = oa.solve(x0, goal[:2], budget, shifted, box, link)
            status, obj, lb, it, msg = sol.status, sol.objective, sol.lower_bound, sol.iterations, sol.message
            capped = budget.capped  # the message says so too (oa)
            u, faces, terms = (None, None, None) if sol.plan is None else (sol.plan.u, sol.plan.y, sol.plan.s)
            work, guarded = sol.work, sol.guarded_from
        if u is None:
            return replace(self._failed(status, t0, msg, lb), work_seconds=work, capped=capped)
        controls = np.column_stack([u * KN, np.zeros(len(u))])
        means, covs = self.dynamics.predict_moments(mean, cov, controls)
        gap = max(obj - lb, 0.0) / max(obj, 1.0)
        return Plan(status, obj, lb, gap, it, time.perf_counter() - t0, controls, means, covs, faces, terms,
                    self._in_margin(means[0]), msg, work_seconds=work, guarded_from=guarded,
                    start=np.array(mean, float), capped=capped)

    def _within_limits(self, mean: np.ndarray) -> tuple[np.ndarray, str]:
        """``mean (6,)`` with its ground position clipped to the area and its ground speed
        scaled down to ``speed_max``, and what was changed ("" if nothing).  An estimate
        can leave those limits (the truth cannot, from step 2 on); every plan of P1 starts
        within them."""
        out, why = mean.copy(), []
        out[:2] = np.clip(mean[:2], self.geom.area_lo, self.geom.area_hi)
        if np.any(out[:2] != mean[:2]):
            why.append(f"estimate at ({mean[0]:.1f}, {mean[1]:.1f}) m is outside the area")
        speed = float(np.hypot(mean[3], mean[4]))
        if speed > self.cfg.speed_max:
            out[3:5] *= self.cfg.speed_max / speed
            why.append(f"estimated speed {speed:.1f} m/s is above speed_max")
        return out, "; ".join(why)

    def _failed(self, status, t0, message, lower=np.nan) -> Plan:
        return Plan(status, np.inf, lower, np.inf, 0, time.perf_counter() - t0, None, None, None, message=message)

    def _in_margin(self, mean1: np.ndarray) -> bool:
        return bool(self.geom.polys.contains(mean1[:2]).any())

    def _solve_scip(self, p, x0, goal, box=None, link=None):
        """The same cvxpy model, solved by SCIP (optional extra ``pyscipopt``).

        SCIP runs without a gap limit: cvxpy reports SCIP's gap-limit and time-limit stops
        alike ("optimal_inaccurate"), so only a proved optimum is called "optimal" (gap 0);
        anything else is a time limit with an unknown lower bound.
        """
        import cvxpy as cp

        p.x0.value, p.goal.value = x0, goal
        if p.applied is not None:
            p.applied.value = link
        if p.box is not None:
            p.box.value = np.r_[box[0], box[1]]
        try:
            p.problem.solve(solver=cp.SCIP, scip_params={"limits/time": self.cfg.time_limit},
                            canon_backend=cp.SCIPY_CANON_BACKEND)
        except (cp.error.SolverError, ImportError) as exc:
            return "error", np.inf, np.nan, None, None, None, 0, f"SCIP failed: {exc}"
        status = p.problem.status
        if status == cp.INFEASIBLE:
            return "infeasible", np.inf, np.inf, None, None, None, 0, "SCIP: infeasible"
        if status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
            return "error", np.inf, np.nan, None, None, None, 0, f"SCIP: {status}"
        obj = float(p.problem.value)
        lb = obj if status == cp.OPTIMAL else np.nan
        n, f = p.geom.face_offsets.shape
        y = np.round(p.y.value).reshape(p.horizon - 1, n, f) if n else np.zeros((p.horizon - 1, 0, f))
        terms = np.r_[p.e.value, p.d.value.reshape(-1, order="F"), [] if p.link is None else p.link.value]
        return ("optimal" if status == cp.OPTIMAL else "feasible"), obj, lb, p.u.value, y, terms, 0, "SCIP via cvxpy"


def _shift_warm(plan: Plan, by: int, horizon: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Faces, terms and planned points of ``plan`` ``by`` steps on, fitted to a plan of
    ``horizon`` steps: step tau of the new plan is step tau + by of the old one; missing
    steps repeat the last one (receding horizon) and surplus steps are dropped (shrinking
    horizon).  Points are ``(T-1, 2)`` positions for steps 2..T.  A plan with nothing left
    after the shift (a 2-step plan re-planned at the shortest horizon, 2) repeats its
    last step."""
    rows = horizon - 1

    def fit(a: np.ndarray, full: np.ndarray) -> np.ndarray:
        a = a if len(a) else full[-1:]
        return np.concatenate([a, np.repeat(a[-1:], max(rows - len(a), 0), axis=0)])[:rows]

    old = len(plan.controls) - 1
    d_all = plan.terms[2:2 + 2 * old].reshape(2, -1)  # [d_x..., d_y...] (cvxpy's column-major order)
    d = np.concatenate([d_all[:, by:], np.zeros((2, max(rows - d_all[:, by:].shape[1], 0)))], axis=1)[:, :rows]
    link = plan.terms[2 + 2 * old:]  # the link term's (2,) or nothing: the new plan's is the old increment at by
    if len(link) and 0 < by <= old:
        link = d_all[:, by - 1]
    # old means[k] is p_{k+1}; the new plan's step tau = r + 2 is the old step r + 2 + by = means[r + 1 + by]
    return (fit(plan.faces[by:], plan.faces), np.r_[plan.terms[:2], d.reshape(-1), link],
            fit(plan.means[1 + by:, :2], plan.means[:, :2]))
