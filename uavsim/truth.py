"""The true targets of one trial ([Papaioannou2023] Sec. III-A, VI-B).

Each trial draws every target's true initial state from its prior ``N(mu_0, Sigma_0)``,
restricted to starts from which the target can stay out of every building: the start and
its first step ``p + v dt`` (which no force can change) outside every obstacle inflated
as the guidance inflates it, and a guidance plan from it that keeps every avoidance
constraint from step 2 on (a start from which the target cannot brake or turn in time
has none); it then moves by the mission's truth mode:

* ``planned`` (the paper, Sec. VI-B): along the noise-free guidance plan computed from
  that drawn start at t = 1 (re-planned noise-free from its end if the mission outlasts
  the horizon).  The plan is warm-started from the plan at the prior (the same in every
  trial, so made once per process, and the start of the filter's first re-plans too)
  within ``replan_budget_s``, and solved again cold within ``time_limit_s`` where that
  search is not certified (:func:`true_plan`);
* ``stochastic``: re-planned from the true state every step (with the link term, from the
  force it applied last), moving by Eq. (1) with
  process noise drawn again (at most :data:`NOISE_DRAWS` times) where a draw would carry
  the target into a building: a truncated Gaussian, so that the truth never enters one.

Every step of the truth is checked against the obstacles themselves (the segment from
its last position); a step that touches one is counted (:attr:`Truth.collisions`) and
logged as an event, whatever made it.

A planned truth is a deterministic function of its drawn start, ``x_t = g_t(x_0)``.  Its
sensitivity ``G_t = d x_t / d x_0`` on ``[x, y, vx, vy]`` (:attr:`Truth.sensitivity`) is
what the accuracy floor of :mod:`.bounds.pcrlb` needs: P1's optimum is piecewise affine in the
start (a QP for each face choice and active set), so central differences are exact unless
the active set changes within them (:meth:`.guidance.Guidance.sensitivity` checks; on the
paper mission forward and backward differences agree to 1e-8).

The filter starts from the prior, never from the drawn truth.
"""

from __future__ import annotations

import numpy as np

from .declare import SettingError
from .guidance import Guidance, Plan
from .guidance.model import geometry
from .mission import Mission
from .targets import HORIZONTAL, Target

START_DRAWS = 1000  # prior draws per target to find a free-space true start
PLAN_TRIES = 20  # clear draws tried per target until one has a guidance plan that avoids every obstacle
NOISE_DRAWS = 8  # process-noise draws per step of a stochastic truth, the first clear of the buildings kept


def prior_draws(mission: Mission, rng: np.random.Generator, n: int) -> np.ndarray:
    """(n, M, 6) draws of every target's initial state from its prior ``N(mu_0, Sigma_0)``."""
    means = np.array([t.mean0 for t in mission.targets])
    covs = np.array([t.cov0 for t in mission.targets])
    z = rng.standard_normal((n, *means.shape))  # (n, M, 6)
    return means + np.einsum("mij,dmj->dmi", np.linalg.cholesky(covs), z)


def clear_starts(mission: Mission, ground, draws: np.ndarray) -> np.ndarray:
    """(D, M) which draws ``(D, M, 6)`` the truth may start from: the start and its first
    step ``p + v dt`` outside every obstacle and, where ``ground`` (the guidance's
    inflated footprints, :class:`.world.model.Polygons`) has any, outside those too."""
    world = mission.world
    p0 = world.on_ground(draws[..., :3])
    p1 = world.on_ground(p0 + mission.dynamics.dt * draws[..., 3:])
    free = ~world.in_obstacle(p0) & ~world.segment_blocked(p0, p1)
    if len(ground):
        free &= ~ground.contains(p0[..., :2]).any(axis=-1) & ~ground.contains(p1[..., :2]).any(axis=-1)
    return free


def start_prior(mission: Mission, rng: np.random.Generator, n: int = 4000) -> tuple[np.ndarray, np.ndarray]:
    """The prior the true starts are drawn from: the share of each target's ``N(mu_0,
    Sigma_0)`` that :func:`clear_starts` keeps and the covariance of what it keeps.

    Parameters
    ----------
    mission : its targets' priors, world and guidance margins; rng : the draws' stream;
    n : prior draws per target (the share's binomial standard error is ``sqrt(a (1 - a) / n)``).

    Returns
    -------
    acceptance : (M,) the share kept; below 1 the true starts are the prior restricted.
    cov : (M, 6, 6) ``Sigma_0`` with its ``[x, y, vx, vy]`` block (the one the bound uses)
        the restricted prior's, ``Sigma_0 + (S_kept - S_all)`` with ``S`` the sample
        covariances of the kept and of all n draws on that block: the control variate
        ``S_all - Sigma_0`` removes the sampling error the two share, so a target whose
        draws are all kept gets ``Sigma_0`` exactly (where the difference is not positive
        definite, ``S_kept`` alone).  It leaves out the rarer restriction to starts with a
        guidance plan (events in the trial's log).
    """
    draws = prior_draws(mission, rng, n)
    kept = clear_starts(mission, geometry(mission.world, mission.dynamics, mission.guidance).polys, draws)
    cov = np.array([t.cov0 for t in mission.targets], dtype=float)
    for j in range(draws.shape[1]):  # one target at a time: M is a handful
        x, keep = draws[:, j][:, HORIZONTAL], kept[:, j]
        if keep.all() or keep.sum() < 2 * len(HORIZONTAL):
            continue  # nothing restricted, or too few kept to say how (the start itself then fails)
        s_kept = np.cov(x[keep], rowvar=False)
        c = cov[j][np.ix_(HORIZONTAL, HORIZONTAL)] + s_kept - np.cov(x, rowvar=False)
        cov[j][np.ix_(HORIZONTAL, HORIZONTAL)] = c if np.linalg.eigvalsh(0.5 * (c + c.T)).min() > 0.0 else s_kept
    return kept.mean(axis=0), 0.5 * (cov + np.swapaxes(cov, 1, 2))


def bound_prior(mission: Mission) -> tuple[np.ndarray, np.ndarray] | None:
    """The prior of a planned truth's starts as the PCRLB takes it: :func:`start_prior`
    from 4000 draws seeded by the mission's seed (the same in every summary and
    recording), or None for a stochastic truth (no bound)."""
    return start_prior(mission, np.random.default_rng(mission.seed)) if mission.truth == "planned" else None


def prior_plan(guidance: Guidance, target: Target, goal: np.ndarray) -> Plan | None:
    """The plan from ``target``'s prior ``N(mean0, cov0)`` to ``goal (3,)``, None if there is
    none: the warm start of a true target's first plan, and so of every plan that stands for
    one (the filter's first re-plans, its route probes).  The guidance keeps it (a cold plan)."""
    plan = guidance.plan(target.mean0, target.cov0, goal)
    return plan if plan.ok else None


def true_plan(guidance: Guidance, x: np.ndarray, goal: np.ndarray, warm: Plan | None, step: int = 0) -> Plan:
    """P1 from ``x (6,)`` as a true target plans it: warm-started from ``warm`` (the plan at
    its prior, :func:`prior_plan`) within the re-plan budget, and, where that search is not
    certified optimal, solved again from scratch within the first plan's ``time_limit_s``
    (it is the target's first plan); the usable one (collision-free, every avoidance
    constraint from step 2 on) with the lower Eq. (7) objective flies: a search its budget
    stops keeps its warm start's route, which may be far from P1's (docs/results/towns.md,
    "The truth's own plan").  ``warm`` None (a later horizon's plan): the cold solve alone."""
    zero = np.zeros((6, 6))  # a truth knows its state
    plan = guidance.plan(x, zero, goal, warm=warm, step=step, shift=0)
    if warm is None or plan.status == "optimal":
        return plan
    cold = guidance.plan(x, zero, goal, step=step)
    usable = [p for p in (plan, cold) if p.ok and p.guarded_from == 2]
    return min(usable, key=lambda p: p.objective) if usable else plan


class Truth:
    """True states ``state (M, 6)`` of one trial; ``controls`` then ``move`` each step.

    ``start_rng`` draws the initial states, ``noise_rng`` the process noise (separate
    streams, so both truth modes start from the same draw)."""

    def __init__(self, mission: Mission, guidance: Guidance, start_rng: np.random.Generator,
                 noise_rng: np.random.Generator):
        self.m, self.guidance, self.rng = mission, guidance, noise_rng
        self._candidates = self._start(start_rng)
        self.state = np.array([c[0] for c in self._candidates])
        self.plans: list[Plan | None] = [None] * len(mission.targets)
        self.sensitivity: np.ndarray | None = None  # (M, 4, 4) d x_t / d x_0 on HORIZONTAL (planned)
        self.notes: list[str] = []
        self.collisions = 0  # truth steps that touched an obstacle
        if mission.truth == "planned":
            self.sensitivity = np.broadcast_to(np.eye(4), (len(mission.targets), 4, 4)).copy()
            self.plans = self._noise_free_plans(0)

    def _start(self, rng: np.random.Generator) -> list[np.ndarray]:
        """Per target the ``(k, 6)`` clear draws among ``START_DRAWS`` from the prior, in
        order (see module docstring): the first is the true start unless a planned truth
        has no plan from it.  A fixed number of draws, so the stream does not depend on
        where the obstacles are."""
        draws = prior_draws(self.m, rng, START_DRAWS)
        free = clear_starts(self.m, self.guidance.geom.polys, draws)
        if not free.any(axis=0).all():
            j = int(np.argmin(free.any(axis=0)))
            raise SettingError(f"targets[{j}].cov0_si",
                               f"none of {START_DRAWS} draws from the prior is outside the obstacles' margins "
                               "and clear of them after one step")
        return [draws[free[:, j], j] for j in range(draws.shape[1])]

    def _noise_free_plans(self, step: int) -> list[Plan]:
        plans, self._segment, self._segment_start = [], [], self.sensitivity.copy()
        for j in range(len(self.state)):
            plan = self._first_plan(j, step)
            x = self.state[j]
            plans.append(plan)
            try:
                g, smooth = self.guidance.sensitivity(x, self.m.goals[j], plan, step)
            except RuntimeError as exc:
                raise SettingError(f"targets[{j}].position_m", f"the truth's plan: {exc}") from None
            if not smooth:
                self.notes.append(f"{self.m.targets[j].name} (truth): the plan's active constraints change within "
                                  "a millimetre of the start; its sensitivity is the central difference across it")
            self._segment.append(g)
        return plans

    def _first_plan(self, j: int, step: int) -> Plan:
        """Target j's noise-free plan from its state; at step 0 from the first of its clear
        prior draws that has one keeping every avoidance constraint (at most
        ``PLAN_TRIES``: a draw near the area's edge, heading out faster than the force limit
        can turn, or towards a wall it cannot stop short of, has none), noted as an event."""
        goal = self.m.goals[j]
        tries = self._candidates[j][:PLAN_TRIES] if step == 0 else self.state[j:j + 1]
        # the filter's first re-plans and its route probes start from the same plan
        warm = prior_plan(self.guidance, self.m.targets[j], goal) if step == 0 else None
        failed: list[Plan] = []
        for x in tries:
            plan = true_plan(self.guidance, x, goal, warm, step)
            if plan.ok and (plan.guarded_from == 2 or step > 0):
                if failed:
                    why = f"{failed[0].status}: {failed[0].message}" if not failed[0].ok else failed[0].message
                    self.notes.append(f"{self.m.targets[j].name} (truth): {len(failed)} draw(s) from the prior had "
                                      f"no guidance plan that avoids every obstacle ({why}); the start is the next "
                                      "clear draw")
                self.state[j] = x
                return plan
            failed.append(plan)
        first = failed[0]
        raise SettingError(f"targets[{j}].position_m",
                           f"no guidance plan that avoids every obstacle for the truth from {len(tries)} start(s) "
                           f"({first.status}: {first.message})")

    def drain_notes(self) -> list[str]:
        """The events noted since the last call."""
        notes, self.notes = self.notes, []
        return notes

    def controls(self, t: int, events: list[str]) -> np.ndarray:
        """(M, 3) the forces the true targets apply at step t (module docstring)."""
        events += self.drain_notes()
        if self.m.truth == "planned":
            k = t % len(self.plans[0].controls)
            if t and k == 0:  # the mission outlasts the horizon: plan on from the end
                self.plans = self._noise_free_plans(t)
            return np.array([plan.controls[k] for plan in self.plans])
        zero = np.zeros((6, 6))
        self.plans = [self.guidance.replan(x, zero, self.m.goals[j], p, t,
                                           applied=None if p is None else p.controls[0])
                      for j, (x, p) in enumerate(zip(self.state, self.plans))]
        events += [f"{self.m.targets[j].name} (truth): {p.message}" for j, p in enumerate(self.plans)
                   if p.eventful]
        return np.array([p.controls[0] for p in self.plans])

    def move(self, t: int, controls: np.ndarray) -> None:
        """Eq. (1): exactly along the plan (``planned``), or with process noise kept clear
        of the buildings (module docstring); every step checked against the obstacles."""
        before = self.state
        if self.m.truth == "planned":
            k = t % len(self.plans[0].controls)
            self.state = np.array([plan.means[k] for plan in self.plans])
            self.sensitivity = np.array([g[k] for g in self._segment]) @ self._segment_start
        else:
            self.state = self.m.dynamics.step(before, controls, rng=self.rng)
            for _ in range(NOISE_DRAWS - 1):  # draw again only for the targets whose step enters a building
                again = self._blocked(before, self.state)
                if not again.any():
                    break
                redrawn = self.m.dynamics.step(before[again], controls[again], rng=self.rng)
                self.state = self.state.copy()
                self.state[again] = redrawn
        hit = self._blocked(before, self.state)
        for j in np.flatnonzero(hit):
            self.collisions += 1
            self.notes.append(f"{self.m.targets[j].name} (truth): step {t + 1} touches an obstacle between "
                              f"({before[j, 0]:.1f}, {before[j, 1]:.1f}) and ({self.state[j, 0]:.1f}, "
                              f"{self.state[j, 1]:.1f}) m")

    def _blocked(self, before: np.ndarray, after: np.ndarray) -> np.ndarray:
        """(..., M) bool: the straight step from ``before (M, 6)`` to ``after (..., M, 6)``
        touches an obstacle (on the ground: z raised to the floor, see :meth:`World.on_ground`)."""
        world = self.m.world
        return world.segment_blocked(world.on_ground(before[..., :3]), world.on_ground(after[..., :3]))
