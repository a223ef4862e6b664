"""The closed loop of 004_22b452551a772073.txt Sec. V-VI, one trial at a time.

Each step t -> t+1:

1. **guidance**: every target's P1 is re-solved from its posterior ``N(mu_t, Sigma_t)``
   (Eq. 8c, rolling horizon), warm-started from its previous plan; a failed re-plan
   falls back to the previous plan shifted by one step (an event is logged);
2. **filter predict** (Eq. 9a) with each plan's first control;
3. **UAV**: ``optimized`` takes the admissible grid move of least summed predicted
   covariance trace (Eq. 12-13); a manoeuvre flies its loop; ``fixed-sensors`` has three
   static sensors instead of a UAV;
4. **truth**: every trial draws each target's true initial state from its prior
   ``N(mu_0, Sigma_0)`` (restricted to free space: a start inside an obstacle is drawn
   again), then ``planned`` (the paper, Sec. VI-B): the target follows the noise-free
   guidance plan computed from that drawn start at t = 1 (re-planned noise-free from its
   end if a mission outlasts the horizon); ``stochastic``: targets are re-planned on
   their true states every step and move by Eq. (1) with process noise;
5. **sense and update** (Eq. 4, 9b-11), then systematic resampling when the ESS is low.

The filter starts from the prior, never from the drawn truth.  The ``baseline`` planner
has no sensor at all: its filter only predicts, so it measures what the prior and the
guidance model alone know (the no-information baseline of every study).

Randomness: a trial gets one ``SeedSequence``; it spawns separate streams for the truth's
process noise, the sensor, the filter, the UAV start and the truth's initial state, so
trial k sees the same truth and the same prior particles whichever planner runs (common
random numbers across planners and the baseline).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from .config import Mission, MissionError
from .filtering import ParticleFilter, PseudoLinearTracks, scan_loglik
from .guidance import Guidance, Plan
from .planning import decide, gaussian_traces, pseudo_traces
from .sensing import Scan, observe
from .uav import MANOEUVRES, admissible, candidates, manoeuvre_route

PLANNERS = ("optimized", *MANOEUVRES, "fixed-sensors", "baseline")
START_DRAWS = 1000  # prior draws per target to find a free-space true start
STAGES = ("guidance", "filter", "planner", "truth", "total")


@dataclass
class StepInfo:
    """What one step produced (for recording and metrics).  Shapes: M targets, N particles."""

    t: int
    truth: np.ndarray  # (M, 6)
    mean: np.ndarray  # (M, 6) posterior means
    cov: np.ndarray  # (M, 6, 6)
    observers: np.ndarray  # (S, 3) sensor positions this step (the UAV, or the fixed sensors)
    scans: list[Scan]
    plans: list[Plan]
    candidates: np.ndarray | None  # (C, 3) the UAV's grid moves (optimized planner)
    scores: np.ndarray | None  # (C,) summed pseudo-posterior traces (inf: not admissible)
    seconds: dict[str, float]
    events: list[str] = field(default_factory=list)
    particles: np.ndarray | None = None  # (M, N, 6) posterior particles (a copy)


class Simulation:
    """One trial of the closed loop: ``reset(seed)``, then ``step()`` until done.

    Parameters
    ----------
    mission : validated mission; planner : one of :data:`PLANNERS`;
    guidance : a shared :class:`Guidance` (it is stateless; building one costs ~30 ms);
    oracle : the filter predicts with the true targets' own forces instead of re-planning
        from its estimate (a diagnostic: it separates tracking errors due to guidance from
        the rest; ``benchmarks/worlds.py`` uses it).
    """

    def __init__(self, mission: Mission, planner: str, guidance: Guidance | None = None, oracle: bool = False):
        if planner not in PLANNERS:
            raise ValueError(f"unknown planner {planner!r}; choose from {', '.join(PLANNERS)}")
        self.m, self.planner, self.oracle = mission, planner, oracle
        self.guidance = guidance or Guidance(mission.world, mission.dynamics, mission.guidance)
        self.goals = np.array([mission.world.goals[t.goal].centroid for t in mission.targets])

    # ------------------------------------------------------------------ reset
    def reset(self, seed: np.random.SeedSequence | int) -> StepInfo:
        if isinstance(seed, np.random.SeedSequence):  # a fresh copy: spawning twice from one object differs
            ss = np.random.SeedSequence(seed.entropy, spawn_key=seed.spawn_key, pool_size=seed.pool_size)
        else:
            ss = np.random.SeedSequence(seed)
        truth_ss, sensor_ss, filter_ss, uav_ss, start_ss = ss.spawn(5)
        self.rng_truth, self.rng_sensor, self.rng_filter = map(np.random.default_rng, (truth_ss, sensor_ss, filter_ss))
        m = self.m
        means0 = np.array([t.mean0 for t in m.targets])
        covs0 = np.array([t.cov0 for t in m.targets])
        self.truth = self._true_start(np.random.default_rng(start_ss), means0, covs0)
        if m.filter.kind == "particle":
            self.est = ParticleFilter.from_priors(self.rng_filter, means0, covs0, m.filter.particles)
        else:
            self.est = PseudoLinearTracks(m.filter.kind, means0, covs0, m.guidance.speed_max)
        self.t = 0
        self.plans: list[Plan | None] = [None] * len(m.targets)
        self.truth_plans: list[Plan | None] = [None] * len(m.targets)
        if m.truth == "planned":
            self.truth_path = self._noise_free_plans(self.truth)
        self.uav = self._start(np.random.default_rng(uav_ss))
        self.route = manoeuvre_route(self.planner, self.uav, m.planner.manoeuvres, m.uav, m.world, m.path) \
            if self.planner in MANOEUVRES else None
        mean, cov = self.est.moments()
        return StepInfo(0, self.truth.copy(), mean, cov, self._observers(), [], [], None, None, {},
                        particles=self._particles())

    def _true_start(self, rng: np.random.Generator, means: np.ndarray, covs: np.ndarray) -> np.ndarray:
        """(M, 6) true initial states: per target the first of ``START_DRAWS`` draws from
        ``N(mean, cov)`` that is outside every obstacle and stays out during its first step
        ``p + v dt``, which no force can change (a target cannot start inside a wall or
        about to hit one).  A fixed number of draws, so the stream does not depend on where
        the obstacles are."""
        z = rng.standard_normal((START_DRAWS, *means.shape))  # (D, M, 6)
        draws = means + np.einsum("mij,dmj->dmi", np.linalg.cholesky(covs), z)
        world = self.m.world
        p0 = world.on_ground(draws[..., :3])
        p1 = world.on_ground(p0 + self.m.dynamics.dt * draws[..., 3:])
        free = ~world.in_obstacle(p0) & ~world.segment_blocked(p0, p1)  # (D, M)
        if not free.any(axis=0).all():
            j = int(np.argmin(free.any(axis=0)))
            raise MissionError(self.m.path, f"targets[{j}].cov0_si",
                               f"none of {START_DRAWS} draws from the prior is outside the obstacles "
                               "and clear of them after one step")
        return draws[np.argmax(free, axis=0), np.arange(len(means))]

    def _start(self, rng: np.random.Generator, tries: int = 10_000) -> np.ndarray:
        """The UAV's start: the mission's, or uniform in the region (area) at altitude h,
        outside obstacles (rejection sampling, in batches; fixed draw count per batch)."""
        uav, world = self.m.uav, self.m.world
        if not uav.random_start or self.planner in ("fixed-sensors", "baseline"):
            return uav.start.copy()
        lo, hi = world.area_lo[:2], world.area_hi[:2]
        if uav.region is not None:
            lo, hi = np.maximum(lo, uav.region.vertices.min(0)), np.minimum(hi, uav.region.vertices.max(0))
        for _ in range(tries // 100):
            p = np.column_stack([rng.uniform(lo, hi, (100, 2)), np.full(100, uav.altitude)])
            ok = ~world.in_obstacle(p) & (uav.region.contains(p) if uav.region is not None else True)
            if ok.any():
                return p[np.argmax(ok)]
        raise MissionError(self.m.path, "uav.random_start",
                           f"no free start found in {tries} draws: the operating region is (nearly) all obstacle")

    def _noise_free_plans(self, starts: np.ndarray) -> list[Plan]:
        """Per target, the noise-free plan from ``starts`` (its means are the true path)."""
        plans = []
        for j, x in enumerate(starts):
            plan = self.guidance.plan(x, np.zeros((6, 6)), self.goals[j])
            if not plan.ok:
                raise MissionError(self.m.path, f"targets[{j}].position_m",
                                   f"no guidance plan from this start for the truth ({plan.status}: {plan.message})")
            plans.append(plan)
        return plans

    def _observers(self) -> np.ndarray:
        if self.planner == "fixed-sensors":
            return self.m.planner.fixed_sensors.positions
        if self.planner == "baseline":
            return np.zeros((0, 3))
        return self.uav[None, :]

    # ------------------------------------------------------------------ step
    def step(self) -> StepInfo:
        m, sec, events = self.m, {}, []
        t0 = time.perf_counter()
        truth_controls = self._truth_controls(events)
        sec["truth"] = time.perf_counter() - t0

        t1 = time.perf_counter()
        if not self.oracle:
            mean, cov = self.est.moments()
            self.plans = [self._replan(j, mean[j], cov[j], self.plans[j], events, "estimate")
                          for j in range(len(mean))]
        sec["guidance"] = time.perf_counter() - t1

        t2 = time.perf_counter()
        controls = truth_controls if self.oracle else np.array([p.controls[0] for p in self.plans])
        dyn = m.dynamics
        self.est.predict(self.rng_filter, dyn.a, dyn.b, dyn.q_chol, controls)
        sec["filter"] = time.perf_counter() - t2

        t3 = time.perf_counter()
        cands, scores = self._move_uav()
        sec["planner"] = time.perf_counter() - t3

        t4 = time.perf_counter()
        self._move_truth(truth_controls)
        sec["truth"] += time.perf_counter() - t4

        t5 = time.perf_counter()
        observers = self._observers()
        sensor = m.planner.fixed_sensors.sensor if self.planner == "fixed-sensors" else m.sensor
        scans = [observe(self.rng_sensor, sensor, self.truth[:, :3], o) for o in observers]
        self._update(scans, observers, sensor, events)
        mean, cov = self.est.moments()
        sec["filter"] += time.perf_counter() - t5
        sec["total"] = time.perf_counter() - t0
        self.t += 1
        plans = [] if self.oracle else self.plans
        return StepInfo(self.t, self.truth.copy(), mean, cov, observers, scans, plans, cands, scores, sec, events,
                        self._particles())

    def _particles(self) -> np.ndarray | None:
        return self.est.particles.copy() if isinstance(self.est, ParticleFilter) else None

    def _update(self, scans: list[Scan], observers: np.ndarray, sensor, events: list[str]) -> None:
        m = self.m
        if not scans:  # the baseline: no sensor, the prediction is the posterior
            return
        if isinstance(self.est, PseudoLinearTracks):  # clutter-free: each sensor's scan in turn
            for scan, o in zip(scans, observers):
                for j in np.flatnonzero(self.est.update(scan, o, sensor.sigma)):
                    events.append(f"{m.targets[j].name}: degenerate {m.filter.kind} update skipped")
            return
        loglik = sum(scan_loglik(s, self.est.particles, o, sensor) for s, o in zip(scans, observers))
        degenerate = self.est.update(loglik)
        for j in np.flatnonzero(degenerate):
            events.append(f"{m.targets[j].name}: degenerate update skipped (no particle explains the bearings)")
        resampled = self.est.resample(self.rng_filter, m.filter.resample_threshold, m.filter.roughening)
        if resampled.any():
            events.append("resampled " + ", ".join(m.targets[j].name for j in np.flatnonzero(resampled)))

    def _replan(self, j: int, mean, cov, previous: Plan | None, events: list[str], who: str) -> Plan:
        plan = self.guidance.plan(mean, cov, self.goals[j], warm=previous, horizon=self.guidance.horizon_at(self.t))
        if plan.ok:
            return plan
        name = self.m.targets[j].name
        if previous is None:  # nothing to fall back on: coast (zero force) until a plan exists
            events.append(f"{name} ({who}): no plan ({plan.status}: {plan.message}); coasting")
            controls = np.zeros((self.guidance.horizon_at(self.t), 3))
            means, covs = self.m.dynamics.predict_moments(mean, cov, controls)
            return replace(plan, status="fallback", controls=controls, means=means, covs=covs)
        events.append(f"{name} ({who}): re-plan {plan.status} ({plan.message}); flying the previous plan")
        return previous.shifted(self.m.dynamics, mean, cov, plan.message)

    def _move_uav(self) -> tuple[np.ndarray | None, np.ndarray | None]:
        if self.planner == "optimized":
            cands = candidates(self.uav, self.m.uav)
            ok = admissible(self.uav, cands, self.m.world, self.m.uav)
            sigma, est = self.m.sensor.sigma, self.est
            if isinstance(est, ParticleFilter):
                best, scores = decide(cands, ok, lambda c: pseudo_traces(c, est.particles, est.weights, sigma))
            else:
                best, scores = decide(cands, ok, lambda c: gaussian_traces(c, est.mean, est.cov, sigma))
            if np.isfinite(scores[best]):
                self.uav = cands[best]
            return cands, scores
        if self.route is not None:
            self.uav = self.route.position(self.t + 1)
        return None, None

    def _truth_controls(self, events: list[str]) -> np.ndarray:
        """(M, 3) the forces the true targets apply this step: their noise-free plans'
        (``planned``; re-planned from the end when the mission outlasts them), or a fresh
        plan from each true state (``stochastic``)."""
        if self.m.truth == "planned":
            k = self.t % len(self.truth_path[0].controls)
            if self.t and k == 0:  # the mission outlasts the horizon: plan on from the end
                self.truth_path = self._noise_free_plans(self.truth)
            return np.array([plan.controls[k] for plan in self.truth_path])
        zero = np.zeros((6, 6))
        self.truth_plans = [self._replan(j, x, zero, self.truth_plans[j], events, "truth")
                            for j, x in enumerate(self.truth)]
        return np.array([p.controls[0] for p in self.truth_plans])

    def _move_truth(self, controls: np.ndarray) -> None:
        """Eq. (1): noise-free along the plan (``planned``: exactly its mean path), or with
        process noise (``stochastic``)."""
        if self.m.truth == "planned":
            k = self.t % len(self.truth_path[0].controls)
            self.truth = np.array([plan.means[k] for plan in self.truth_path])
            return
        self.truth = self.m.dynamics.step(self.truth, controls, rng=self.rng_truth)
