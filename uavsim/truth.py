"""The true targets of one trial ([Papaioannou2023] Sec. III-A, VI-B).

Each trial draws every target's true initial state from its prior ``N(mu_0, Sigma_0)``
(restricted to starts outside every obstacle that stay out during their first step
``p + v dt``, which no force can change, and for a planned truth to starts with a
guidance plan), then moves it by the mission's truth mode:

* ``planned`` (the paper, Sec. VI-B): along the noise-free guidance plan computed from
  that drawn start at t = 1 (re-planned noise-free from its end if the mission outlasts
  the horizon);
* ``stochastic``: re-planned from the true state every step, moving by Eq. (1) with
  process noise.

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
from .mission import Mission

START_DRAWS = 1000  # prior draws per target to find a free-space true start
PLAN_TRIES = 20  # clear draws tried per target until one has a guidance plan (planned truth)


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
        if mission.truth == "planned":
            self.sensitivity = np.broadcast_to(np.eye(4), (len(mission.targets), 4, 4)).copy()
            self.plans = self._noise_free_plans(0)

    def _start(self, rng: np.random.Generator) -> list[np.ndarray]:
        """Per target the ``(k, 6)`` clear draws among ``START_DRAWS`` from the prior, in
        order (see module docstring): the first is the true start unless a planned truth
        has no plan from it.  A fixed number of draws, so the stream does not depend on
        where the obstacles are."""
        means = np.array([t.mean0 for t in self.m.targets])
        covs = np.array([t.cov0 for t in self.m.targets])
        z = rng.standard_normal((START_DRAWS, *means.shape))  # (D, M, 6)
        draws = means + np.einsum("mij,dmj->dmi", np.linalg.cholesky(covs), z)
        world = self.m.world
        p0 = world.on_ground(draws[..., :3])
        p1 = world.on_ground(p0 + self.m.dynamics.dt * draws[..., 3:])
        free = ~world.in_obstacle(p0) & ~world.segment_blocked(p0, p1)  # (D, M)
        if not free.any(axis=0).all():
            j = int(np.argmin(free.any(axis=0)))
            raise SettingError(f"targets[{j}].cov0_si",
                               f"none of {START_DRAWS} draws from the prior is outside the obstacles "
                               "and clear of them after one step")
        return [draws[free[:, j], j] for j in range(len(means))]

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
        prior draws that has one (at most ``PLAN_TRIES``: a draw near the area's edge,
        heading out faster than the force limit can turn, has none), noted as an event."""
        tries = self._candidates[j][:PLAN_TRIES] if step == 0 else self.state[j:j + 1]
        failed: list[Plan] = []
        for x in tries:
            plan = self.guidance.plan(x, np.zeros((6, 6)), self.m.goals[j], step=step)
            if plan.ok:
                if failed:
                    self.notes.append(f"{self.m.targets[j].name} (truth): {len(failed)} draw(s) from the prior had "
                                      f"no guidance plan ({failed[0].status}: {failed[0].message}); the start is "
                                      "the next clear draw")
                self.state[j] = x
                return plan
            failed.append(plan)
        first = failed[0]
        raise SettingError(f"targets[{j}].position_m",
                           f"no guidance plan for the truth from {len(tries)} start(s) "
                           f"({first.status}: {first.message})")

    def controls(self, t: int, events: list[str]) -> np.ndarray:
        """(M, 3) the forces the true targets apply at step t (module docstring)."""
        events += self.notes
        self.notes = []
        if self.m.truth == "planned":
            k = t % len(self.plans[0].controls)
            if t and k == 0:  # the mission outlasts the horizon: plan on from the end
                self.plans = self._noise_free_plans(t)
            return np.array([plan.controls[k] for plan in self.plans])
        zero = np.zeros((6, 6))
        self.plans = [self.guidance.replan(x, zero, self.m.goals[j], self.plans[j], t)
                      for j, x in enumerate(self.state)]
        events += [f"{self.m.targets[j].name} (truth): {p.message}" for j, p in enumerate(self.plans)
                   if p.eventful]
        return np.array([p.controls[0] for p in self.plans])

    def move(self, t: int, controls: np.ndarray) -> None:
        """Eq. (1): exactly along the plan (``planned``), or with process noise."""
        if self.m.truth == "planned":
            k = t % len(self.plans[0].controls)
            self.state = np.array([plan.means[k] for plan in self.plans])
            self.sensitivity = np.array([g[k] for g in self._segment]) @ self._segment_start
        else:
            self.state = self.m.dynamics.step(self.state, controls, rng=self.rng)
