"""The closed loop of [Papaioannou2023] Sec. V-VI, one trial at a time.

Each step t -> t+1:

1. **truth forces**: the true targets' controls (:mod:`.truth`);
2. **guidance**: every target's P1 is re-solved from its posterior ``N(mu_t, Sigma_t)``
   (Eq. 8c, rolling horizon; or from each half of its particle cloud, step 3),
   warm-started from its previous plan (at the first step from its plan at the prior
   mean, the same in every trial); a failed re-plan
   falls back to the previous plan shifted by one step (an event is logged).  With
   ``[guidance] link_applied_force`` each re-plan also weighs the step from the force
   its particles moved by last (each particle keeps its own; a half's re-plan takes its
   weighted mean, :meth:`.belief.Belief.applied`);
3. **belief predict** (Eq. 9a) with each plan's first control; with ``[filter] keep_out``
   the particles it carries into an obstacle then weigh zero (the prior was restricted to
   the true starts' test, :func:`.truth.clear_starts`).  With ``[filter]
   plan_clusters = 2`` each particle cloud is split in two (:func:`.belief.particle.halves`)
   and each half moves by the first control of a plan from its own mean and covariance
   (warm-started from the previous step's half plan nearest it; no plan is made from the
   mean of a split cloud, see :meth:`Simulation._plan_controls`).  A plan depends on the start's
   velocity as much as on its position, and on which side of an obstacle it lies, so one
   plan from the mean moves the whole cloud by a force that fits neither part of a
   spread or split cloud (on 50 generated worlds, ``benchmarks/worlds.py``, two plans
   halved the targets lost against a filter handed the truth's forces; docs/methods/filter.md).  A cloud
   with a half holding less than :data:`MIN_HALF` of the weight moves by the plan from its mean.
   With ``[filter] motion = "commit"`` nothing is re-planned: at the first step each cloud
   is split into ``plan_clusters`` clusters (:func:`.belief.particle.clusters`; those of a
   reference cloud drawn from the prior, the same in every trial, which the particles join:
   :meth:`Simulation.first_commit`; with ``[filter] route_probes`` a cluster is added for
   each route a probe start takes that no cluster's model follows), each
   cluster is planned once from its mean (warm-started from the plan at the prior), and a
   particle flies its cluster's plan open loop, its force corrected by the plan's response
   to its own start (:meth:`.guidance.Guidance.gains`), as a planned truth flies the plan
   made from its drawn start; when the plans' horizon ends the clouds are clustered and
   planned again, as the truth re-plans (:meth:`Simulation._commit_controls`); with
   ``[filter] route_switch`` a particle may take a neighbouring cluster's plan instead
   (:mod:`.belief.particle`);
4. **UAV**: the policy moves (:mod:`.uav`: Eq. 12-13 grid moves, a manoeuvre, fixed
   sensors, no sensor), or takes the move given to :meth:`Simulation.step`;
5. **truth moves**, then **sense and update** (Eq. 4, 9b-11) from the policy's observers;
   a track the belief declares lost (``[filter] loss_nats``, :mod:`.belief.particle`) is
   re-seeded from the scans, within its reach from the prior, and the routes to its goal
   (:mod:`.belief.recovery`) and logged as a track-loss event.

Randomness: a trial gets one ``SeedSequence``; it spawns separate streams for the truth's
process noise, the sensor, the filter, the UAV start and the truth's initial state (and a
sixth for the metrics' draws from the belief, which the trial never reads), so
trial k sees the same truth and the same prior particles whichever policy runs (common
random numbers across policies and the baseline).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np

from .belief import choice, make_belief, recovery
from .belief.particle import nearest_clusters, reference_clusters, restricted_draws
from .guidance import Guidance, Plan
from .mission import Mission
from .sensing import Scan
from .targets import HORIZONTAL
from .truth import Truth, clear_starts, prior_plan
from .uav import make_policy
from .uav.grid import every_move_ties
from .world.routes import GoalField
from .world.space import DepthGrid

__all__ = ["Simulation", "StepInfo", "target_bearings"]  # the public interface (docs/api.md renders each)

STAGES = ("guidance", "filter", "planner", "truth", "total")  # seconds per step; "planner": the policy's act
MIN_HALF = 0.01  # a cloud with a half of less weight than this moves by the plan from its mean
MAX_ROUTE_CLUSTERS = 8  # clusters a target's route probes may add (Simulation._probe_routes)
REFERENCE_SEED = 0  # the stream of the cloud the first step's clusters are drawn from (Simulation.first_commit)


@dataclass
class StepInfo:
    """What one step produced (for recording and metrics).  Shapes: M targets, N particles."""

    t: int
    truth: np.ndarray  # (M, 6)
    mean: np.ndarray  # (M, 6) posterior means
    cov: np.ndarray  # (M, 6, 6)
    observers: np.ndarray  # (S, 3) sensor positions this step (the UAV, the fixed sensors, or none)
    scans: list[Scan]
    plans: list[Plan]
    candidates: np.ndarray | None  # (C, 3) the UAV's grid moves (the optimized policy)
    scores: np.ndarray | None  # (C,) Eq. (13)'s summed traces (weighted policy: weighted sum); inf: not admissible
    seconds: dict[str, float]
    events: list[str] = field(default_factory=list)
    particles: np.ndarray | None = None  # (M, N, 6) posterior particles (a copy)
    uav: np.ndarray | None = None  # (3,) the UAV's position, None when no UAV flies
    sensitivity: np.ndarray | None = None  # (M, 4, 4) d truth / d true start on [x, y, vx, vy] (planned truth)


class FirstCommit(NamedTuple):
    """The first step's committed clusters, made once per guidance (:meth:`Simulation.first_commit`)."""

    reference: tuple  # the reference cloud's clusters (belief.particle.reference_clusters, with route probes added)
    plans: list[list[Plan]]  # per target, its clusters' plans
    gains: np.ndarray  # (M, K, T, 3, 4) their gains
    events: list[str]  # what making them reported
    capped: int  # solves the wall-clock cap stopped while making them (counted at every reuse)


class Simulation:
    """One trial of the closed loop: ``reset(seed)``, then ``step()`` until done.

    Parameters
    ----------
    mission : validated mission; planner : the policy's name, one of :data:`uavsim.uav.PLANNERS`;
    guidance : a shared :class:`Guidance` (it is stateless; building one costs ~30 ms);
    oracle : the filter predicts with the true targets' own forces instead of re-planning
        from its estimate (a diagnostic: it separates tracking errors due to guidance from
        the rest; ``benchmarks/worlds.py`` uses it).
    """

    def __init__(self, mission: Mission, planner: str, guidance: Guidance | None = None, oracle: bool = False):
        self.m, self.oracle = mission, oracle
        self.policy = make_policy(planner, mission)
        self.guidance = guidance or Guidance(mission.world, mission.dynamics, mission.guidance)
        self._fields: dict = {}  # goal index -> GoalField (track recovery)
        # the targets' priors: mu_0 (M, 6) and Sigma_0 (M, 6, 6)
        self.means0 = np.array([t.mean0 for t in mission.targets])
        self.covs0 = np.array([t.cov0 for t in mission.targets])
        self.means0.flags.writeable = self.covs0.flags.writeable = False  # every trial starts from them

    def reset(self, seed: np.random.SeedSequence | int) -> StepInfo:
        if isinstance(seed, np.random.SeedSequence):  # a fresh copy: spawning twice from one object differs
            ss = np.random.SeedSequence(seed.entropy, spawn_key=seed.spawn_key, pool_size=seed.pool_size)
        else:
            ss = np.random.SeedSequence(seed)
        # the sixth stream is for checks that must not touch the trial (the metrics' draws from the belief)
        truth_rng, self.rng_sensor, filter_rng, uav_rng, start_rng, self.rng_check = map(np.random.default_rng,
                                                                                         ss.spawn(6))
        m = self.m
        self.truth = Truth(m, self.guidance, start_rng, truth_rng)
        self.belief = make_belief(m.filter, filter_rng, self.means0, self.covs0, m.guidance.speed_max,
                                  tuple(t.name for t in m.targets), self._clear)
        self.t, self._prepared = 0, False
        self.plans: list[Plan | None] = [None] * len(m.targets)
        self.half_plans: list[list[Plan]] = [[] for _ in m.targets]  # per target: this step's two half plans, or none
        self.committed: list[list[Plan]] = []  # motion = "commit": per target its clusters' plans
        self._gains = np.zeros((0, 0, 0, 3, 4))  # (M, K, T, 3, 4) their gains
        self._committed_at = 0  # the step they were made at
        self.policy.reset(uav_rng)
        return self._info([], [], (None, None), {}, [])

    def prepare(self) -> None:
        """The first half of a step, once per step: the truth's forces, every target's
        re-plan and the belief's prediction.  After it the belief is the predicted one the
        UAV decides on (:meth:`uavsim.uav.GridOptimizer.choose`)."""
        if self._prepared:
            return
        m, sec, events = self.m, {}, []
        t0 = time.perf_counter()
        self._truth_controls = self.truth.controls(self.t, events)
        sec["truth"] = time.perf_counter() - t0
        t1 = time.perf_counter()
        split = None
        if self.oracle:
            controls = self._truth_controls
        elif m.filter.motion == "commit":
            controls = None
        else:
            previous, shift = self.plans, 1
            if self.t == 0:  # the first re-plans start from the plans at the priors (made once per process)
                previous, shift = [self._prior_plan(j) for j in range(len(m.targets))], 0
            controls, split = self._plan_controls(previous, shift, events)
        sec["guidance"] = time.perf_counter() - t1
        t2 = time.perf_counter()
        if controls is None:
            self.belief.predict_committed(m.dynamics, *self._commit_controls(events))
        else:
            self.belief.predict(m.dynamics, controls, split)
        if m.filter.keep_out:
            events += self.belief.keep_out(self._inside)
        events += self.belief.drain_notes()
        sec["filter"] = time.perf_counter() - t2
        self._prepared, self._sec, self._events = True, sec, events

    def step(self, action: int | None = None) -> StepInfo:
        """One step; ``action``: the UAV's next grid move (an index into the candidates of
        Eq. 3) instead of the policy's own choice (``optimized`` only)."""
        self.prepare()
        sec, events = self._sec, self._events
        t3 = time.perf_counter()
        forecast = None if self.oracle else [p.means for p in self.plans]
        moves = self.policy.act(self.t, self.belief, action, forecast)
        if action is None and every_move_ties(moves[1]):
            events.append("UAV: every admissible move ties in Eq. (13) (no move's bearing tells more than another's); "
                          "broken toward the flight that pays, if one does (docs/methods/decision.md, Ties)")
        sec["planner"] = time.perf_counter() - t3
        t4 = time.perf_counter()
        self.truth.move(self.t, self._truth_controls)
        events += self.truth.drain_notes()
        sec["truth"] += time.perf_counter() - t4
        t5 = time.perf_counter()
        observers, sensor = self.policy.observers, self.policy.sensor
        scans = [sensor.draw(self.rng_sensor, self.truth.state[:, :3], o) for o in observers]
        events += self.belief.update(scans, observers, sensor)
        if scans and self.belief.lost.any():
            events += self._recover(scans, observers, sensor)
        sec["filter"] += time.perf_counter() - t5
        sec["total"] = sum(sec[k] for k in STAGES[:-1])  # the stages cover the step (prepare may run earlier)
        self.t += 1
        self._prepared = False
        return self._info(scans, [] if self.oracle else self.plans, moves, sec, events)

    @property
    def replans(self) -> list[Plan]:
        """The re-plans of the last step, each once: a split target's two half plans (its
        :attr:`plans` entry is one of them), else its plan from the mean; none under the oracle."""
        if self.oracle or self.t == 0:
            return []
        if self.m.filter.motion == "commit":  # the committed plans, at the step they were made
            return [p for plans in self.committed for p in plans] if self._committed_at == self.t - 1 else []
        return [p for plan, halves in zip(self.plans, self.half_plans) for p in (halves or [plan])]

    def _clear(self, states: np.ndarray) -> np.ndarray:
        """``(M, K)`` bool: which of the states ``(M, K, 6)`` a true target may start from
        (:func:`.truth.clear_starts`)."""
        return clear_starts(self.m, self.guidance.geom.polys, states.transpose(1, 0, 2)).T

    def _inside(self, positions: np.ndarray) -> np.ndarray:
        """``(M, N)`` bool: which of the positions ``(M, N, 3)`` (a cloud per target) lie in
        an obstacle; a cloud at a time, so each meets only the obstacles near it."""
        w = self.m.world
        return np.stack([w.in_obstacle(p) for p in w.on_ground(positions)])

    def _recover(self, scans, observers, sensor) -> list[str]:
        """Re-seed the tracks the belief declares lost, each from the routes to its goal and
        within its reach from the prior after the ``t + 1`` steps the truth has made."""
        goal = [t.goal for t in self.m.targets]
        radii = recovery.reach(self.means0, self.covs0, self.t + 1, self.m.dynamics.dt, self.m.guidance.speed_max,
                               self.m.dynamics.q if self.m.truth == "stochastic" else None)
        return self.belief.recover(scans, observers, sensor, self.m.world, lambda j: self._field(goal[j]),
                                   self.m.filter.reseed_share, (self.means0[:, :2], radii))

    def _field(self, goal: int):
        """The route field to world goal ``goal`` (built once per simulation, when first needed)."""
        if goal not in self._fields:
            w = self.m.world
            self._fields[goal] = GoalField(w.goals[goal].centroid, w.ground(0.0)[1], w.area_lo, w.area_hi)
        return self._fields[goal]

    def _info(self, scans, plans, moves, seconds, events) -> StepInfo:
        mean, cov = self.belief.moments()
        return StepInfo(self.t, self.truth.state.copy(), mean, cov, self.policy.observers, scans, plans, *moves,
                        seconds, events, self.belief.samples(), self.policy.uav,
                        None if self.truth.sensitivity is None else self.truth.sensitivity.copy())

    def _replan(self, j: int, mean, cov, warm: Plan | None, events: list[str], who: str = "estimate",
                shift: int = 1, applied: np.ndarray | None = None) -> Plan:
        """A re-plan warm-started from ``warm`` (made ``shift`` steps ago); ``applied (2,)``:
        the mean force the particles it moves moved by last (:meth:`.guidance.Guidance.linked`)."""
        plan = self.guidance.replan(mean, cov, self.m.goals[j], warm, self.t, shift, applied)
        if plan.eventful:
            events.append(f"{self.m.targets[j].name} ({who}): {plan.message}")
        return plan

    def _prior_plan(self, j: int) -> Plan | None:
        """Target j's plan from its prior mean, the same in every trial (the guidance keeps
        it), None if there is none."""
        return prior_plan(self.guidance, self.m.targets[j], self.m.goals[j])

    def _plan_controls(self, previous: list[Plan | None], shift: int, events: list[str]
                       ) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray] | None]:
        """Every target's re-plan (step 2 of the module docstring): ``(M, 3)`` first controls,
        and with ``plan_clusters = 2`` the split ``(mask (M, N), (M, 3))`` of the second
        halves' controls (None otherwise).  ``previous[j]``: target j's plan made ``shift``
        steps ago, the warm start.

        A target whose halves both hold at least :data:`MIN_HALF` of the weight is planned
        from its halves only, each warm-started from the previous step's half plan that
        predicted its mean best (or from ``previous[j]``); its plan (:attr:`plans`, the
        forecast and the recording's) is the heavier half's.  The others are planned from
        the mean."""
        mean, cov = self.belief.moments()
        m = len(mean)
        applied = self.belief.applied()
        if self.m.filter.plan_clusters != 2:
            self.plans = [self._replan(j, mean[j], cov[j], previous[j], events, shift=shift, applied=applied[j])
                          for j in range(m)]
            return np.array([p.controls[0] for p in self.plans]), None
        mask, mass, means, covs = self.belief.halves()
        half_applied = self.belief.applied(mask)
        both = np.empty((m, 2, 3))
        plans: list[Plan] = []
        for j in range(m):
            if mass[j].min() < MIN_HALF:
                plans.append(self._replan(j, mean[j], cov[j], previous[j], events, shift=shift, applied=applied[j]))
                both[j] = plans[-1].controls[0]
                self.half_plans[j] = []
                continue
            halves = [self._replan(j, means[j, h], covs[j, h], self._half_warm(j, means[j, h], previous[j], shift),
                                   events, f"estimate, half {h + 1}", shift=shift, applied=half_applied[j, h])
                      for h in range(2)]
            both[j] = [p.controls[0] for p in halves]
            plans.append(halves[int(mass[j, 1] > mass[j, 0])])
            self.half_plans[j] = halves
        self.plans = plans
        return both[:, 0], (mask, both[:, 1])

    def _commit_controls(self, events: list[str]) -> tuple[np.ndarray, np.ndarray]:
        """``motion = "commit"`` (module docstring): this step's force of every cluster's plan
        ``(M, K, 3)`` and its gains ``(M, K, 3, 4)``; at the first step, and when the plans
        run out, the clouds are clustered and planned anew.  A target's :attr:`plans` entry
        is its heaviest cluster's plan from this step on."""
        k = self.m.filter.plan_clusters
        age = self.t - self._committed_at
        if self.t == 0:
            first = self.first_commit(k)
            reference, self.committed, self._gains = first.reference, first.plans, first.gains
            label = None if self.m.filter.route_choice == "nearest" else self._choose_routes(first)
            mass = self.belief.commit(reference[0].shape[1], reference, reference[0].shape[1] - k, label)[2]
            events += first.events
        elif age >= len(self.committed[0][0].controls):
            means, covs, mass = self.belief.commit(k)
            self.committed, self._gains = self._cluster_plans(means, covs, [None] * len(means), events)
            self._committed_at, age = self.t, 0
        else:
            mass = self.belief.cluster_mass(len(self.committed[0]))
        self.plans = [_from_step(plans[int(np.argmax(w))], age) for plans, w in zip(self.committed, mass)]
        return np.array([[p.controls[age] for p in plans] for plans in self.committed]), self._gains[:, :, age]

    def first_commit(self, k: int) -> FirstCommit:
        """The first step's clusters (:func:`.belief.particle.reference_clusters` of a cloud
        drawn from the priors with :data:`REFERENCE_SEED`, restricted as the belief's is), their
        plans (warm-started from the plans at the priors), gains and events: the same in every
        trial, so made once and kept with the guidance (a campaign's worker keeps its guidance
        for all its trials).  Each trial's particles join these clusters (their cells).  With
        ``[filter] route_probes`` the reference cloud's first starts are planned too, and each
        whose plan no cluster's model follows becomes a cluster (:meth:`_probe_routes`)."""
        m = self.m
        means0, covs0 = self.means0, self.covs0
        key = ("first commit", k, m.filter.particles, m.filter.keep_out, m.filter.route_probes, means0.tobytes(),
               covs0.tobytes(), np.array(m.goals).tobytes())
        if key in self.guidance.kept:  # its capped solves (Plan.capped) count in every trial that reuses it
            self.guidance.capped += self.guidance.kept[key].capped
        else:
            capped = self.guidance.capped
            clear = self._clear if m.filter.keep_out else None
            cloud = restricted_draws(np.random.default_rng(REFERENCE_SEED), means0, covs0, m.filter.particles, clear)[0]
            reference = reference_clusters(cloud, k)
            events: list[str] = []
            plans, gains = self._cluster_plans(*reference[:2], [self._prior_plan(j) for j in range(len(m.targets))],
                                               events)
            if m.filter.route_probes:
                reference, plans, gains = self._probe_routes(cloud[:, :m.filter.route_probes], reference, plans, gains)
            for a in (*reference, gains):
                a.flags.writeable = False  # shared by every trial that keeps this guidance
            self.guidance.kept[key] = FirstCommit(reference, plans, gains, events, self.guidance.capped - capped)
        return self.guidance.kept[key]

    def route_models(self, first: FirstCommit) -> list[tuple]:
        """Per target, its first committed clusters' models ``(states, sens)``
        (:func:`.belief.choice.cluster_models`) and their Eq. (7) quadratic
        (:func:`.belief.choice.eq7_quadratic`): ``[(states, sens, quad), ...]``."""
        out = []
        for j, row in enumerate(first.plans):
            controls = np.array([p.controls for p in row])  # (K, T, 3): every first plan spans the horizon
            states, sens = choice.cluster_models(first.reference[0][j], controls, first.gains[j], self.m.dynamics)
            out.append((states, sens, choice.eq7_quadratic(states, sens, controls, first.gains[j], self.m.goals[j],
                                                           self.m.guidance.rho, self.m.guidance.link)))
        return out

    def _choose_routes(self, first: FirstCommit) -> np.ndarray:
        """``(M, N)`` the reference cluster each particle flies: the cheapest clear plan of its
        clusters as ``route_choice`` says (:mod:`.belief.choice`)."""
        means, _, scale, live = first.reference
        particles = self.belief.pf.particles
        order = nearest_clusters(particles, means, scale, live, means.shape[1])
        if "depth grid" not in self.guidance.kept:
            g = self.guidance.geom
            self.guidance.kept["depth grid"] = DepthGrid.build(g.polys, g.area_lo, g.area_hi)
        depth = self.guidance.kept["depth grid"]
        keep = self.m.filter.route_choice == "clear"
        return np.stack([choice.cheapest(particles[j], order[j], means[j], states, sens, quad, depth, keep)
                         for j, (states, sens, quad) in enumerate(self.route_models(first))])

    def _probe_routes(self, probes: np.ndarray, reference: tuple, plans: list[list[Plan]], gains: np.ndarray
                      ) -> tuple[tuple, list[list[Plan]], np.ndarray]:
        """The first step's clusters with a cluster added for each route they miss.  Each of
        ``probes (M, P, 6)`` (starts drawn as the reference cloud's) is planned as a truth
        from it would be; where its plan's positions leave every cluster's model (the
        cluster's plan plus its gains times the probe's offset, :func:`model_positions`) by
        more than :func:`route_gap` at some step, the probe becomes a cluster: its state the
        mean, its plan, the gains there, the nearest cluster's covariance.  Probes a cluster
        added before fits are skipped; at most :data:`MAX_ROUTE_CLUSTERS` a target.  Every
        target's clusters are padded with empty ones (not live, never joined) to the most
        any target has.  ``reference``, ``plans``, ``gains``: as :meth:`first_commit` makes them."""
        means, covs, scale, live = reference
        added = [self._route_clusters(j, starts, means[j][live[j]], covs[j][live[j]],
                                      [p for p, on in zip(plans[j], live[j]) if on], gains[j][live[j]], scale[j])
                 for j, starts in enumerate(probes)]
        extra = max(map(len, added))
        if not extra:
            return reference, plans, gains
        blank = [(means[j, 0], covs[j, 0], plans[j][0], np.zeros_like(gains[j, 0])) for j in range(len(means))]
        cols = [list(zip(*(row + [blank[j]] * (extra - len(row))))) for j, row in enumerate(added)]  # M x 4 lists
        more = [np.array([c[i] for c in cols]) for i in (0, 1, 3)]  # (M, extra, ...) means, covs, gains
        live = np.concatenate([live, np.arange(extra) < np.array([len(row) for row in added])[:, None]], axis=1)
        return ((np.concatenate([means, more[0]], axis=1), np.concatenate([covs, more[1]], axis=1), scale, live),
                [p + list(c[2]) for p, c in zip(plans, cols)], np.concatenate([gains, more[2]], axis=1))

    def _route_clusters(self, j: int, starts: np.ndarray, mu: np.ndarray, cv: np.ndarray, pl: list[Plan],
                        gn: np.ndarray, scale: np.ndarray) -> list[tuple]:
        """Target j's clusters added for ``starts (P, 6)`` (:meth:`_probe_routes`), each
        ``(mean (6,), cov (6, 6), plan, gains (T, 3, 4))``, given its live clusters' means
        ``mu (K, 6)``, covariances ``cv``, plans ``pl`` and gains ``gn (K, T, 3, 4)`` and the
        clustering's ``scale (4,)``."""
        added: list[tuple] = []
        # planned as the truth's first search from x is (truth.true_plan): warm from truth.prior_plan, kept
        # uncertified; a search its budget stops keeps its warm start's route, so another warm start finds others.
        # Not the truth's cold search too: on osm-north 109 of 244 probes were uncertified, and their cold searches made
        # the first commit 3.3 times as long (docs/results/towns.md, "The truth's own plan")
        warm = self._prior_plan(j)
        for x in starts:
            near = int(np.argmin(((mu - x)[:, HORIZONTAL] ** 2 / scale**2).sum(1)))
            own = self.guidance.plan(x, cv[near], self.m.goals[j], warm=warm, step=self.t, shift=0)
            if not (own.ok and own.guarded_from == 2) or own.moved_start or len(own.controls) != len(pl[0].controls):
                continue
            flown = model_positions(x, mu, np.array([p.controls for p in pl]), gn, self.m.dynamics)
            if np.linalg.norm(flown - own.means[None, :, :2], axis=2).max(1).min() <= route_gap(scale):
                continue
            try:
                g = self.guidance.gains(x, self.m.goals[j], own, self.t)[0]
            except RuntimeError:  # no plan from a start moved by the sensitivity's step
                continue
            added.append((x, cv[near], own, g))
            mu, cv, gn = np.vstack([mu, x[None]]), np.vstack([cv, cv[near][None]]), np.vstack([gn, g[None]])
            pl = pl + [own]
            if len(added) == MAX_ROUTE_CLUSTERS:
                break
        return added

    def _cluster_plans(self, means: np.ndarray, covs: np.ndarray, warm: list[Plan | None], events: list[str]
                       ) -> tuple[list[list[Plan]], np.ndarray]:
        """Every target's plan from each of its clusters' ``means (M, k, 6)`` and ``covs
        (M, k, 6, 6)``, warm-started from ``warm[j]``, and their gains ``(M, k, T, 3, 4)``."""
        plans = [[self._replan(j, means[j, c], covs[j, c], warm[j], events, f"estimate, cluster {c + 1}", shift=0)
                  for c in range(means.shape[1])] for j in range(len(means))]
        gains = np.array([[self._plan_gains(j, means[j, c], p, events) for c, p in enumerate(row)]
                          for j, row in enumerate(plans)])
        return plans, gains

    def _plan_gains(self, j: int, start: np.ndarray, plan: Plan, events: list[str]) -> np.ndarray:
        """``(T, 3, 4)`` target j's plan's gains (:meth:`.guidance.Guidance.gains`) at the
        cluster's mean ``start``; zero for a fallback plan or where no plan exists from a
        moved start (an event).  A plan made from another start (the nearest within the
        limits, or at rest: :meth:`.guidance.Guidance.replan`) gets the central difference
        at ``start`` all the same (the two one-sided differences from the plan's own means
        cancel that offset), or zero where no plan exists there."""
        zero = np.zeros((len(plan.controls), 3, 4))
        if plan.status == "fallback":
            return zero
        try:
            return self.guidance.gains(start, self.m.goals[j], plan, self.t)[0]
        except RuntimeError as exc:
            events.append(f"{self.m.targets[j].name} (estimate): its cluster's particles fly the plan's forces "
                          f"unchanged ({exc})")
            return zero

    def _half_warm(self, j: int, start: np.ndarray, previous: Plan | None, shift: int) -> Plan | None:
        """The warm start of a half of target j's cloud with mean ``start (6,)``: of the
        previous step's half plans, the one whose prediction of this step lies nearest
        ``start`` in position; ``previous`` if there are none (or at the first step)."""
        last = self.half_plans[j] if shift == 1 else []
        if not last:
            return previous
        miss = [np.hypot(*(p.means[0, :2] - start[:2])) for p in last]
        return last[int(np.argmin(miss))]


def model_positions(start: np.ndarray, means: np.ndarray, controls: np.ndarray, gains: np.ndarray, dynamics
                    ) -> np.ndarray:
    """``(K, T, 2)`` the positions ``start (6,)`` flies under each of K committed clusters'
    models: the cluster's plan ``controls (K, T, 3)`` plus its ``gains (K, T, 3, 4)`` times the
    start's ``[x, y, vx, vy]`` offset from the cluster's mean ``means (K, 6)``, noise-free
    (Eq. 1), as a committed particle without noise flies."""
    d = start[HORIZONTAL] - means[:, HORIZONTAL]  # (K, 4)
    x, out = np.repeat(start[None], len(means), axis=0), np.empty((*controls.shape[:2], 2))
    for t in range(controls.shape[1]):
        x = x @ dynamics.a.T + (controls[:, t] + np.einsum("kij,kj->ki", gains[:, t], d)) @ dynamics.b.T
        out[:, t] = x[:, :2]
    return out


def route_gap(scale: np.ndarray) -> float:
    """The gap (m) past which a start's plan is a route its cluster's model misses
    (:meth:`Simulation._probe_routes`): the prior's position standard deviation, the root
    mean square of ``scale (4,)``'s x and y (a cloud's spread)."""
    return float(np.sqrt((scale[0] ** 2 + scale[1] ** 2) / 2.0))


def _from_step(plan: Plan, age: int) -> Plan:
    """``plan`` from its step ``age`` on (the same object at 0)."""
    if not age:
        return plan
    return replace(plan, controls=plan.controls[age:], means=plan.means[age:], covs=plan.covs[age:],
                   faces=None if plan.faces is None else plan.faces[age:])


def target_bearings(infos: list[StepInfo], target: int, dt: float, sensor: int = 0
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One target's own bearings of a recorded trial, for the estimator library:
    ``times (K,)`` s, ``bearings (K,)`` rad in the ``"north-cw"`` convention (Eq. 4; NaN
    where the scan missed the target; false alarms left out), ``observers (K, 2)`` m and
    the true positions ``(K, 2)``, from the steps ``infos`` that carry scans (``step()``'s
    results; the first, ``reset()``'s, has none).  ``sensor``: which observer's scans."""
    steps = [i for i in infos if i.scans]
    bearings = np.full(len(steps), np.nan)
    for k, info in enumerate(steps):
        scan = info.scans[sensor]
        hit = np.flatnonzero(scan.from_target[target] & scan.valid[target])
        if len(hit):
            bearings[k] = scan.bearings[target, hit[0]]
    return (np.array([i.t * dt for i in steps]), bearings, np.array([i.observers[sensor, :2] for i in steps]),
            np.array([i.truth[target, :2] for i in steps]))
