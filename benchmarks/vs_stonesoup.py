"""uavsim against Stone Soup on the same problems, interleaved in one process.

    pip install -e ".[bench]"    # Stone Soup
    taskset -c 0 python benchmarks/vs_stonesoup.py [--steps 200] [--decisions 5] [--json docs/data/vs-stonesoup.json]

1. **Filter step**, 1 target, N = 5000, the paper's sensor (Lambda = 1, p_D = 0.95,
   sigma = 1 deg), a target moving by Eq. (1) seen from a moving observer:

   * uavsim: predict (Eq. 9a), Eq. (10) likelihood, update, resampling when the ESS falls
     below N / 2, moments (Eq. 11);
   * Stone Soup's plain particle filter: ``ParticlePredictor`` with the same linear
     Gaussian model, ``ParticleUpdater`` with ``ESSResampler`` (threshold N / 2,
     systematic), ``mean`` and ``covar`` of the posterior.  Its measurement is the whole
     scan (one ``Detection`` holding the set); Eq. (10) is the ``logpdf`` of a Stone Soup
     measurement model, :class:`ClutteredBearings`, which calls uavsim's likelihood, so the
     two differ only in the filter machinery around it (checked: same posterior weights);
   * Stone Soup's Bernoulli particle filter (``BernoulliParticlePredictor`` and
     ``BernoulliParticleUpdater``, ``Cartesian2DToBearing`` detections, clutter density
     Lambda / 2 pi): its update is Eq. (10) up to a constant when the target exists
     (checked: same weights), but it also tracks the existence probability, adds birth
     particles (500, drawn from the prior) and resamples back to N every step.

   The controls are zero: Stone Soup's Bernoulli predictor has no control input.
2. **Decision** (Eq. 12-13), 61 moves x 4 targets x 5000 particles: uavsim's
   ``decide(pseudo_traces)`` against Stone Soup's ``BruteForceSensorManager`` moving a
   platform with a ``RadarBearing`` sensor over the same 61 positions, its reward the
   summed trace reduction after a particle update with the noise-free bearing of each
   track's mean (``UncertaintyRewardFunction`` with ``trace`` in place of the Frobenius
   norm: Eq. 13), the tracks' particles already predicted (as uavsim's are).  Checked:
   both choose the same move.

Figures are medians (and minima) of per-call wall time; the implementations alternate
call by call so machine load hits them alike.
"""

from __future__ import annotations

import copy
import sys
import time
from datetime import datetime, timedelta
from pathlib import Path

import numpy as np

try:
    import stonesoup  # noqa: F401
except ImportError:
    print("Stone Soup is not installed: pip install -e '.[bench]' (or pip install stonesoup); nothing to compare")
    sys.exit(0)

from harness import parser, run
from stonesoup.base import Property
from stonesoup.models.measurement.base import MeasurementModel
from stonesoup.models.measurement.nonlinear import Cartesian2DToBearing
from stonesoup.models.transition.linear import LinearGaussianTimeInvariantTransitionModel
from stonesoup.movable.action.move_position_action import MovePositionAction, SamplePositionActionGenerator
from stonesoup.movable.sample import _SampleActionableMovable
from stonesoup.platform.base import FixedPlatform
from stonesoup.predictor.base import Predictor
from stonesoup.predictor.particle import BernoulliParticlePredictor, ParticlePredictor
from stonesoup.resampler.particle import ESSResampler, SystematicResampler
from stonesoup.sampler.detection import DetectionSampler
from stonesoup.sensor.radar.radar import RadarBearing
from stonesoup.sensor.sensor import Sensor as SensorBase
from stonesoup.sensormanager.base import BruteForceSensorManager
from stonesoup.sensormanager.reward import UncertaintyRewardFunction
from stonesoup.types.array import StateVector, StateVectors
from stonesoup.types.detection import Detection, TrueDetection
from stonesoup.types.groundtruth import GroundTruthState
from stonesoup.types.hypothesis import SingleHypothesis
from stonesoup.types.multihypothesis import MultipleHypothesis
from stonesoup.types.prediction import Prediction
from stonesoup.types.state import BernoulliParticleState, ParticleState, State
from stonesoup.types.track import Track
from stonesoup.updater.particle import BernoulliParticleUpdater, ParticleUpdater

from uavsim.belief.particle import ParticleFilter
from uavsim.belief.traces import bearing_traces
from uavsim.config import load_mission
from uavsim.sensing import BearingModel, log_likelihood, observe, scan_loglik, wrap_angle
from uavsim.uav import candidates, decide

ROOT = Path(__file__).resolve().parents[1]
T0 = datetime(2026, 1, 1)
DT = timedelta(seconds=1)
N_BIRTH = 500


# --------------------------------------------------------------------------- Stone Soup models
class ClutteredBearings(MeasurementModel):
    """Eq. (10) as a Stone Soup measurement model: a detection's state vector is the
    whole scan (``n x 1`` bearings in uavsim's convention, from north clockwise)."""

    observer: np.ndarray = Property(doc="(2,) sensor position")
    sensor: BearingModel = Property(doc="uavsim sensor settings")

    @property
    def ndim_meas(self):
        return 1

    def function(self, state, noise=False, **kwargs):
        sv = state.state_vector
        return StateVectors([np.arctan2(sv[0] - self.observer[0], sv[1] - self.observer[1])])

    def rvs(self, num_samples=1, **kwargs):
        raise NotImplementedError("benchmark model: scans come from uavsim.sensing.observe")

    def pdf(self, state1, state2, **kwargs):
        return np.exp(self.logpdf(state1, state2))

    def logpdf(self, state1, state2, **kwargs):
        bearings = np.asarray(state1.state_vector, float).reshape(1, -1)
        expected = np.asarray(self.function(state2), float)  # (1, N)
        return log_likelihood(bearings, np.ones_like(bearings, bool), expected, self.sensor)[0]


class PriorBirths(DetectionSampler):
    """Birth particles for the Bernoulli filter drawn from a Gaussian (a bearing gives no
    range, so they cannot be drawn around the detections)."""

    mean: np.ndarray = Property(doc="(6,)")
    cov: np.ndarray = Property(doc="(6, 6)")
    nsamples: int = Property(default=N_BIRTH)
    rng: np.random.Generator = Property(default=None)

    def sample(self, detections, **kwargs):
        draws = self.rng.multivariate_normal(self.mean, self.cov, self.nsamples)
        return ParticleState(StateVectors(draws.T), log_weight=np.full(self.nsamples, -np.log(self.nsamples)))


class GridActions(SamplePositionActionGenerator):
    """uavsim's candidate moves (Eq. 3) as Stone Soup position actions; row 0 stays."""

    offsets: np.ndarray = Property(doc="(C, 2) moves")

    def __iter__(self):
        for dx, dy in self.offsets:
            target = StateVector(self.current_value.copy())
            target[0] += dx
            target[1] += dy
            yield MovePositionAction(generator=self, end_time=self.end_time, target_value=target)


class GridMovable(_SampleActionableMovable):
    generator = GridActions
    _generator_kwargs = _SampleActionableMovable._generator_kwargs | {"offsets"}
    offsets: np.ndarray = Property(default=None, doc="(C, 2) moves")


class Predicted(Predictor):
    """The tracks are already predicted (uavsim's decision sees predicted particles)."""

    def predict(self, prior, timestamp=None, **kwargs):
        return Prediction.from_state(prior, timestamp=timestamp)


class TraceReward(UncertaintyRewardFunction):
    """Stone Soup's ``UncertaintyRewardFunction`` with the covariance trace (Eq. 13) in
    place of its Frobenius norm; otherwise its code (1.9.1)."""

    def __call__(self, config, tracks, metric_time, *args, **kwargs):
        reward, predicted_sensors, memo = 0.0, set(), {}
        for actionable, actions in config.items():
            predicted = copy.deepcopy(actionable, memo)
            predicted.add_actions(actions)
            predicted.act(metric_time, noise=False)
            if isinstance(actionable, SensorBase):
                predicted_sensors.add(predicted)
        predicted_tracks = []
        for track in tracks:
            predicted_track = copy.copy(track)
            predicted_track.append(self.predictor.predict(predicted_track, timestamp=metric_time))
            predicted_tracks.append(predicted_track)
        for sensor in predicted_sensors:
            truths = {GroundTruthState(t.mean, timestamp=t.timestamp): t for t in predicted_tracks}
            for det in sensor.measure(set(truths), noise=False):
                if isinstance(det, TrueDetection):
                    track = truths[det.groundtruth_path]
                    update = self.updater.update(SingleHypothesis(track.state, det))
                    reward += np.trace(track.covar) - np.trace(update.covar)
        return reward


# --------------------------------------------------------------------------- filter step
def filter_setup(n: int):
    mission = load_mission(ROOT / "missions" / "paper.toml")
    target = mission.targets[0]
    dyn = mission.dynamics
    transition = LinearGaussianTimeInvariantTransitionModel(transition_matrix=dyn.a, covariance_matrix=dyn.q)
    prior_rng = np.random.default_rng(1)
    ours = ParticleFilter.from_priors(prior_rng, target.mean0[None], target.cov0[None], n)
    start = ours.particles[0].T.copy()
    plain = ParticleState(StateVectors(start), log_weight=np.full(n, -np.log(n)), timestamp=T0)
    bern = BernoulliParticleState(StateVectors(start.copy()), log_weight=np.full(n, -np.log(n)),
                                  existence_probability=1.0 - 1e-6, timestamp=T0)
    s = mission.sensor
    predictors = {
        "plain": ParticlePredictor(transition),
        "bernoulli": BernoulliParticlePredictor(
            transition, birth_probability=0.01, survival_probability=0.99,
            birth_sampler=PriorBirths(mean=target.mean0, cov=target.cov0, rng=np.random.default_rng(4))),
    }
    updaters = {
        "plain": ParticleUpdater(None, resampler=ESSResampler()),
        "bernoulli": BernoulliParticleUpdater(None, clutter_rate=s.clutter_rate, clutter_distribution=1 / (2 * np.pi),
                                              detection_probability=s.p_detect, nsurv_particles=n,
                                              resampler=SystematicResampler()),
    }
    return mission, ours, {"plain": plain, "bernoulli": bern}, predictors, updaters


def bearing_detections(scan, observer, sigma, when):
    """One uavsim scan as Stone Soup ``Cartesian2DToBearing`` detections (bearings from +x
    anticlockwise: pi/2 - phi)."""
    model = Cartesian2DToBearing(ndim_state=6, mapping=(0, 1), noise_covar=np.array([[sigma**2]]),
                                 translation_offset=StateVector(observer[:2]))
    phis = scan.bearings[0][scan.valid[0]]
    return [Detection(StateVector([wrap_angle(np.pi / 2 - p)]), timestamp=when, measurement_model=model) for p in phis]


def stonesoup_step(kind, state, predictor, updater, scan, observer, sensor, when):
    prediction = predictor.predict(state, timestamp=when)
    if kind == "plain":
        model = ClutteredBearings(ndim_state=6, mapping=(0, 1), observer=observer[:2], sensor=sensor)
        det = Detection(StateVector(scan.bearings[0][scan.valid[0]].reshape(-1, 1)), timestamp=when,
                        measurement_model=model)
        post = updater.update(SingleHypothesis(prediction, det))
    else:
        dets = bearing_detections(scan, observer, sensor.sigma, when)
        hyps = [SingleHypothesis(prediction, d) for d in dets] or [SingleHypothesis(prediction, None)]
        post = updater.update(MultipleHypothesis(hyps))
    post.mean, post.covar  # noqa: B018 (the moments, as uavsim's step computes them)
    return post


def check_same_weights(mission, ours, states, updaters, scan, observer):
    """The Stone Soup updates give uavsim's posterior weights on the same particles."""
    particles = ours.particles[0].T
    want = scan_loglik(scan, ours.particles, observer, mission.sensor)[0]
    want = want - want.max()
    for kind in ("plain", "bernoulli"):
        pred = Prediction.from_state(states[kind], state_vector=StateVectors(particles.copy()), timestamp=T0 + DT)
        up = copy.copy(updaters[kind])
        up.resampler = None
        if kind == "plain":
            model = ClutteredBearings(ndim_state=6, mapping=(0, 1), observer=observer[:2], sensor=mission.sensor)
            det = Detection(StateVector(scan.bearings[0][scan.valid[0]].reshape(-1, 1)), timestamp=T0 + DT,
                            measurement_model=model)
            post = up.update(SingleHypothesis(pred, det))
        else:
            dets = bearing_detections(scan, observer, mission.sensor.sigma, T0 + DT)
            post = up.update(MultipleHypothesis([SingleHypothesis(pred, d) for d in dets]))
        got = np.asarray(post.log_weight, float) - np.asarray(pred.log_weight, float)
        err = np.max(np.abs((got - got.max()) - want))
        print(f"  check: Stone Soup {kind} update vs Eq. (10): largest log-weight difference {err:.1e}")
        assert err < 1e-8, kind


def filter_benchmark(steps: int, n: int = 5000) -> dict:
    mission, ours, states, predictors, updaters = filter_setup(n)
    dyn, sensor = mission.dynamics, mission.sensor
    world, rng = np.random.default_rng(3), np.random.default_rng(2)
    truth = mission.targets[0].mean0[None].copy()
    zero = np.zeros((1, 3))
    times = {"uavsim": [], "plain": [], "bernoulli": []}
    for k in range(steps):
        truth = dyn.step(truth, zero, world)
        observer = np.array([150.0 + 3 * k, 200.0, 40.0])
        scan = observe(world, sensor, truth[:, :3], observer)
        when = T0 + (k + 1) * DT
        if k == 0:
            check_same_weights(mission, ours, states, updaters, scan, observer)
        for name in np.roll(list(times), k):
            t0 = time.perf_counter()
            if name == "uavsim":
                ours.predict(rng, dyn.a, dyn.b, dyn.q_chol, zero)
                ours.update(scan_loglik(scan, ours.particles, observer, sensor))
                ours.resample(rng, mission.filter.resample_threshold)
                ours.moments()
            else:
                states[name] = stonesoup_step(name, states[name], predictors[name], updaters[name], scan, observer,
                                              sensor, when)
            times[name].append(time.perf_counter() - t0)
    print(f"\nfilter step, 1 target x {n} particles, Lambda = 1, p_D = 0.95, sigma = 1 deg, {steps} steps")
    base = np.median(times["uavsim"])
    labels = {"uavsim": "uavsim", "plain": "Stone Soup particle filter", "bernoulli": "Stone Soup Bernoulli PF"}
    for name, ts in times.items():
        print(f"  {labels[name]:<28} median {1e3 * np.median(ts):7.3f} ms  (min {1e3 * np.min(ts):6.3f})  "
              f"{np.median(ts) / base:5.1f}x uavsim")
    final = {name: np.asarray(states[name].mean, float).ravel()[:2] for name in ("plain", "bernoulli")}
    print(f"  final position estimates: uavsim {np.round(ours.moments()[0][0, :2], 1)}, "
          f"Stone Soup {np.round(final['plain'], 1)} (PF), {np.round(final['bernoulli'], 1)} (Bernoulli); "
          f"truth {np.round(truth[0, :2], 1)}")
    return {"particles": n, "steps": steps,
            "median_s": {k: float(np.median(v)) for k, v in times.items()},
            "min_s": {k: float(np.min(v)) for k, v in times.items()}}


# --------------------------------------------------------------------------- decision
def decision_benchmark(repeats: int, n: int = 5000) -> dict:
    mission = load_mission(ROOT / "missions" / "paper.toml")
    sigma = mission.sensor.sigma
    rng = np.random.default_rng(5)
    means0 = np.array([t.mean0 for t in mission.targets])
    covs0 = np.array([t.cov0 for t in mission.targets])
    pf = ParticleFilter.from_priors(rng, means0, covs0, n)
    pf.logw = np.log(rng.dirichlet(np.ones(n), size=len(means0)))
    uav = np.array([500.0, 500.0, mission.uav.altitude])
    cands = candidates(uav, mission.uav)
    ok = np.ones(len(cands), bool)

    tracks = {Track([ParticleState(StateVectors(p.T), log_weight=lw.copy(), timestamp=T0)])
              for p, lw in zip(pf.particles, pf.logw)}
    radar = RadarBearing(ndim_state=6, position_mapping=(0, 1), noise_covar=np.array([[sigma**2]]))
    movable = GridMovable(states=[State(StateVector(uav), timestamp=T0)], position_mapping=(0, 1, 2),
                          offsets=cands[:, :2] - uav[:2])
    platform = FixedPlatform(movement_controller=movable, sensors=[radar])
    reward = TraceReward(Predicted(None), ParticleUpdater(None))
    manager = BruteForceSensorManager(platforms={platform}, reward_function=reward)

    ours_t, theirs_t = [], []
    for _rep in range(repeats):
        t0 = time.perf_counter()
        best, _ = decide(cands, ok, lambda c: bearing_traces(c, pf.particles, pf.weights, sigma))
        t1 = time.perf_counter()
        config, = manager.choose_actions(tracks, T0)
        t2 = time.perf_counter()
        ours_t.append(t1 - t0)
        theirs_t.append(t2 - t1)
    # the configuration maps every actionable to its actions: the platform's move, and none for the sensor
    chosen = next(a for actions in config.values() for a in actions).target_value
    same = np.allclose(np.asarray(chosen, float).ravel()[:2], cands[best, :2])
    print(f"\nEq. (13) decision, {len(cands)} moves x {len(means0)} targets x {n} particles, {repeats} repeats")
    print(f"  uavsim decide(pseudo_traces)       median {1e3 * np.median(ours_t):8.2f} ms  "
          f"(min {1e3 * np.min(ours_t):7.2f})")
    print(f"  Stone Soup BruteForceSensorManager median {1e3 * np.median(theirs_t):8.2f} ms  "
          f"(min {1e3 * np.min(theirs_t):7.2f})  {np.median(theirs_t) / np.median(ours_t):5.1f}x uavsim")
    print(f"  check: same move chosen: {same} (uavsim move {best})")
    assert same, "Stone Soup chose another move"
    return {"moves": len(cands), "targets": len(means0), "particles": n, "repeats": repeats, "same_move": bool(same),
            "median_s": {"uavsim": float(np.median(ours_t)), "stonesoup": float(np.median(theirs_t))},
            "min_s": {"uavsim": float(np.min(ours_t)), "stonesoup": float(np.min(theirs_t))}}


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--steps", type=int, default=200, help="filter steps")
    ap.add_argument("--decisions", type=int, default=5, help="decision repeats")
    run(measure, ap)


def measure(args) -> dict:
    """The benchmark proper; returns its figures (``harness.run`` writes them with ``--json``)."""
    print(f"Stone Soup {stonesoup.__version__}; medians over interleaved calls")
    return {"stonesoup": stonesoup.__version__, "filter": filter_benchmark(args.steps),
            "decision": decision_benchmark(args.decisions)}


if __name__ == "__main__":
    main()
