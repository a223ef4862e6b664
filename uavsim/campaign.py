"""Monte-Carlo campaigns: trials, their seeds, where they run, what is kept, the metrics.

* **Seeds.** Trial k of a campaign with seed S runs on ``SeedSequence(S).spawn(n)[k]``
  (the k-th child does not depend on n), so its result does not depend on how many
  trials run, in which order, or where.  BLAS runs single-threaded inside every trial,
  so the arithmetic is the same in this process, a local worker or a Dask worker:
  summaries are bit-identical for any number of workers (their ``timing`` and
  ``wall_seconds`` are measurements, not results).
* **Where.** In this process (``workers=1``), a local process pool, or a Dask
  distributed cluster through its ``concurrent.futures`` executor.
* **What is kept.** With an output folder, each finished trial is written to
  ``DIR/trials/trial-KKKKK.npz`` at once, atomically (temporary file, fsync, rename),
  not kept in memory, and the summary is computed from those files; with workers, at
  most two trials per worker are in flight.  So memory does not grow with the trial
  count while the trials run.  ``resume`` runs only the trials without
  a file, after checking ``DIR/campaign.json`` describes the same campaign (the same
  fingerprint; the trial count may differ).  :func:`held` says what a folder holds
  before a run: the command line reuses a finished campaign of the same fingerprint,
  resumes an unfinished one, and refuses another one, saying what differs.
* **One folder, one campaign.** Every trial file carries its index and its campaign's
  key (:func:`trial_key`), and is checked whenever it is read: a file that is
  unreadable, holds another index or another campaign's trial, or a value that is not
  finite, is named, moved to ``DIR/set-aside/`` and run again, never summed.  Trial
  files without a ``campaign.json`` are not reused.  While a campaign writes ``DIR`` it
  holds ``DIR/campaign.lock`` (:func:`campaign_lock`): a second run there is refused,
  naming the first one's process.
* **Failures.** A local worker that dies (the out-of-memory killer's SIGKILL), a Dask
  scheduler that does not answer within :data:`CONNECT_SECONDS`, or a cluster without
  workers for :data:`NO_WORKER_SECONDS`, ends the campaign with :class:`CampaignFailed`:
  one line saying what happened, which trials were running, that the finished ones
  are kept, and how to resume.
* **Metrics** (:mod:`.metrics`): the RMSE of Sec. VI-B per step and target, the
  per-trial mean squared errors (for paired statistics), the average NEES of the position
  (x, y) and of the full state with their 95% chi-square bands; the posterior Cramer-Rao
  bound of the position along the flown paths (:func:`accuracy_floor`: the expectation
  over the campaign's trials), comparable with the RMSE.
* **The no-information baseline.** The ``baseline`` policy runs the same trials with no
  sensor (its filter only predicts).  It does not depend on the sensor, the UAV or the
  ``[planner]`` settings, so its campaign fingerprint leaves them out: one baseline serves
  every policy and clutter rate of a mission.  :func:`with_baseline` adds it to a summary.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import signal
import threading
import time
import warnings
from concurrent.futures import ALL_COMPLETED, FIRST_COMPLETED, BrokenExecutor, ProcessPoolExecutor, wait
from contextlib import contextmanager
from dataclasses import asdict, dataclass, fields, is_dataclass, replace
from multiprocessing import get_context
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from . import metrics
from .bounds.pcrlb import Bound, jackknife_se, pcrlb_planned
from .declare import file_value
from .files import write_atomic
from .guidance import Guidance
from .mission import Mission, mission_errors
from .sim import STAGES, Simulation
from .truth import bound_prior
from .uav import BASELINE, MANOEUVRES, make_policy

__all__ = [  # the public interface (docs/api.md renders each)
    "CampaignError", "CampaignFailed", "CampaignWarning", "Held", "TrialResult", "Work", "campaign_lock",
    "clear", "held", "load_trials", "one_blas_thread", "plan_of_work", "run_campaign", "run_trial", "summarize",
    "trial_seeds", "with_baseline"
]

try:
    import fcntl
except ImportError:  # Windows: campaign folders are not locked
    fcntl = None

FORMAT = 6  # trial-file layout; a folder written in another layout is not resumed


class CampaignError(Exception):
    """A campaign folder or request that cannot be used (reported as a usage error)."""


class CampaignFailed(CampaignError):
    """A campaign that started and could not finish (a worker died, a Dask cluster lost
    its workers): the trials finished before are kept in its folder."""


class CampaignWarning(UserWarning):
    """Something a campaign did that its user should know: a trial file set aside."""


@dataclass(frozen=True)
class TrialResult:
    """One trial's record: squared (x, y) errors ``(steps, M)``, covariance traces
    ``(steps, M)``, NEES of the position and of the state ``(steps, M)``, stage seconds
    ``(steps, len(STAGES))``, guidance statuses, events, and for the PCRLB the true states
    ``(steps, M, 6)``, sensor positions ``(steps, S, 3)`` and the planned truth's
    sensitivity to its start ``(steps, M, 4, 4)`` (``(0,)`` for a stochastic truth);
    ``collisions``: truth steps that touched an obstacle (:attr:`uavsim.truth.Truth.collisions`);
    ``level``: the truth's credible level in the belief ``(steps, M)`` (:func:`uavsim.metrics.credible_level`);
    ``nees_ref``: the position NEES of :data:`REFERENCE_DRAWS` states drawn from each belief
    ``(steps, M, draws)``, a calibrated filter's with these beliefs (:func:`uavsim.metrics.consistency`;
    None in trial files written before it was kept); ``wall_capped``: the trial's plans (the
    truth's, the filter's, cold ones reused from the cache included) that the wall-clock cap
    rather than their work stopped (:attr:`uavsim.guidance.Plan.capped`): where it is not 0
    the trial may differ on another machine or under another load."""

    index: int
    err2: np.ndarray
    trace: np.ndarray
    nees_pos: np.ndarray
    nees_state: np.ndarray
    seconds: np.ndarray
    statuses: dict[str, int]
    events: tuple[str, ...]
    truth: np.ndarray
    observers: np.ndarray
    sensitivity: np.ndarray
    collisions: int = 0
    level: np.ndarray | None = None
    nees_ref: np.ndarray | None = None
    wall_capped: int = 0


REFERENCE_DRAWS = 8  # states drawn from each belief per step for the calibrated reference of the NEES


class trial_seeds:  # noqa: N801 (a lazy list)
    """``SeedSequence(seed).spawn(trials)`` without spawning them all: item k is the k-th
    child, ``SeedSequence(seed, spawn_key=(k,))``, the same sequence ``spawn`` makes, so
    a million trials cost nothing before they run."""

    def __init__(self, seed: int, trials: int):
        self.seed, self.trials = seed, trials

    def __len__(self) -> int:
        return self.trials

    def __getitem__(self, k: int) -> np.random.SeedSequence:
        if not 0 <= k < self.trials:
            raise IndexError(f"trial {k} of {self.trials}")
        return np.random.SeedSequence(self.seed, spawn_key=(k,))


# --------------------------------------------------------------------------- plan of work
# Measured peak memory of a closed-loop step (benchmarks/resources.py): about 450 B per
# target and particle with Lambda = 1 (particles, their copies and the likelihood's
# (K, M, N) terms, K the largest set of a scan), 10 B more per entry of K; guidance
# about 4600 B x T^2 (the condensed programs of one target, T the horizon); 150 MB of
# interpreter and libraries per process.
BYTES_PER_PARTICLE, BYTES_PER_SET_ENTRY, BYTES_PER_HORIZON2, BYTES_PER_PROCESS = 450, 10, 4600, 150e6
SECONDS_PER_PARTICLE_STEP = 1.5e-6  # one target-particle through a step, paper mission, one core
# The sensitivity of a planned truth: 8 QPs with the faces fixed, about a re-plan's cost.
SENSITIVITY_REPLANS = 1.0


@dataclass(frozen=True)
class Work:
    """What a campaign will ask for (:func:`plan_of_work`)."""

    trial_steps: int
    bytes_per_worker: float
    workers: int
    available: float | None  # bytes the machine has free (None: unknown)
    cpu_seconds: float

    @property
    def total_bytes(self) -> float:
        return self.bytes_per_worker * self.workers

    def text(self) -> str:
        return (f"plan of work: {self.trial_steps:,} trial-steps, about {_duration(self.cpu_seconds)} of CPU; "
                f"{self.memory_text()}")

    def memory_text(self) -> str:
        free = f" of {self.available / 2**30:.1f} GiB available" if self.available else ""
        return f"memory about {self.bytes_per_worker / 2**20:,.0f} MiB x {self.workers} worker(s){free}"


def _duration(seconds: float) -> str:
    return f"{seconds:.0f} s" if seconds < 120 else f"{seconds / 60:.0f} min" if seconds < 7200 else \
        f"{seconds / 3600:.1f} h"


def available_memory() -> float | None:
    """Bytes the machine can give (Linux ``MemAvailable``), None where unknown."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024
    except OSError:
        pass
    return None


def guidance_seconds(mission: Mission, guidance: Guidance) -> tuple[float, float]:
    """``(first, replan)``: CPU seconds of a first plan and of a re-plan, each target's mean,
    measured on this mission's world: every target's plan from its prior mean (which
    every trial makes first, and ``guidance`` keeps) and its re-plan one step on,
    warm-started from it.  A world's guidance costs what its streets make it cost (from
    milliseconds on the paper's world to the whole budget in a town): measured, not
    modelled."""
    first, again = [], []
    with one_blas_thread():
        for t, goal in zip(mission.targets, mission.goals):
            t0 = time.process_time()
            plan = guidance.plan(t.mean0, t.cov0, goal)
            first.append(time.process_time() - t0)
            if plan.ok:
                t0 = time.process_time()
                guidance.plan(plan.means[0], plan.covs[0], goal, warm=plan, step=1, shift=1)
                again.append(time.process_time() - t0)
    return float(np.mean(first)), float(np.mean(again)) if again else mission.guidance.replan_budget


def plan_of_work(mission: Mission, workers: int, guidance: tuple[float, float] | None = None,
                 campaigns: int = 1) -> Work:
    """The campaign's size before it runs: memory per worker from the particles x targets
    arrays (and the largest scan set the clutter rate makes likely), the guidance
    programs and the interpreter; CPU time from trials x steps x targets x particles and
    the plans: ``guidance = (first, replan)`` seconds (:func:`guidance_seconds`; without
    them, the budgets: at most that).  Each process makes each target's first plan from
    the prior mean once; each trial makes its truth's plans (warm-started: re-plans) and
    their sensitivity, and every step one re-plan per target and cluster (at most; with
    committed plans, one per cluster with its gains, and again past each horizon).  ``campaigns``:
    how many campaigns of these trials run (planners and the no-information baseline,
    which plans the same)."""
    m, n = len(mission.targets), mission.filter.particles if mission.filter.kind == "particle" else 1
    lam = mission.sensor.clutter_rate
    k = 2 + lam + 4 * np.sqrt(lam + 1)  # a scan's set size rarely exceeds this
    per_worker = (m * n * (BYTES_PER_PARTICLE + BYTES_PER_SET_ENTRY * k)
                  + BYTES_PER_HORIZON2 * mission.guidance.horizon**2 + BYTES_PER_PROCESS)
    trial_steps = campaigns * mission.trials * mission.steps
    workers = max(1, min(workers, mission.trials))
    first, replan = guidance or (mission.guidance.time_limit, mission.guidance.replan_budget)
    plans = mission.filter.plan_clusters  # a split cloud is planned from its halves, not its mean (uavsim.sim)
    if mission.filter.motion == "commit":  # each cluster planned once, with its gains, and again past each horizon
        plans *= (1 + SENSITIVITY_REPLANS) * (1 + mission.steps // mission.guidance.horizon) / mission.steps
    truth = (mission.steps if mission.truth == "stochastic"  # re-planned every step
             else 1 + SENSITIVITY_REPLANS + mission.steps // mission.guidance.horizon)  # and past each horizon
    # the first plans: made here (guidance_seconds) and kept for the campaigns run here, or
    # again by every worker process of every campaign
    firsts = 1 if workers == 1 else 1 + campaigns * workers
    cpu = (trial_steps * m * max(n, 1000) * SECONDS_PER_PARTICLE_STEP + firsts * m * first
           + campaigns * mission.trials * m * replan * (truth + mission.steps * plans))
    return Work(trial_steps, float(per_worker), workers, available_memory(), cpu)


def kept_guidance(mission: Mission) -> Guidance:
    """This process's guidance for the mission's world, dynamics and settings, built once
    (and the plans from the priors it keeps made once): the last two are kept."""
    key = fingerprint(replace(mission, trials=1, steps=1, seed=0))
    if key not in _GUIDANCE:
        while len(_GUIDANCE) >= 2:
            _GUIDANCE.pop(next(iter(_GUIDANCE)))
        _GUIDANCE[key] = Guidance(mission.world, mission.dynamics, mission.guidance)
    return _GUIDANCE[key]


# --------------------------------------------------------------------------- one trial
def one_blas_thread() -> threadpool_limits:
    """BLAS single-threaded, as every trial runs (one worker per core).  A matrix
    product's summation order depends on BLAS's thread count, so whatever must reproduce
    a trial to the last bit (:class:`uavsim.env.UavsimEnv`) runs the same way."""
    return threadpool_limits(limits=1, user_api="blas")


def run_trial(mission: Mission, planner: str, index: int, seed: np.random.SeedSequence,
              guidance: Guidance | None = None, on_step=None, oracle: bool = False) -> TrialResult:
    """Run one trial (BLAS single-threaded); ``on_step(info)`` sees every step; ``oracle``
    see :class:`uavsim.sim.Simulation`."""
    with one_blas_thread(), mission_errors(mission.path):
        sim = Simulation(mission, planner, guidance, oracle)
        capped = sim.guidance.capped
        info = sim.reset(seed)
        if on_step:
            on_step(info)
        err2, trace, nees_pos, nees_state, secs, statuses, events, truth, observers, sens, level, ref = (
            [], [], [], [], [], {}, [], [], [], [], [], [])
        for _ in range(mission.steps):
            info = sim.step()
            if on_step:
                on_step(info)
            err2.append(((info.mean[:, :2] - info.truth[:, :2]) ** 2).sum(axis=1))
            trace.append(np.trace(info.cov, axis1=1, axis2=2))
            nees_pos.append(metrics.state_nees(info.mean, info.cov, info.truth, metrics.POS))
            nees_state.append(metrics.state_nees(info.mean, info.cov, info.truth, metrics.STATE))
            level.append(sim.belief.credible_level(info.truth, info.mean, info.cov))
            ref.append(metrics.draws_nees(info.mean, info.cov, sim.belief.draw(sim.rng_check, REFERENCE_DRAWS)))
            secs.append([info.seconds[k] for k in STAGES])
            truth.append(info.truth)
            observers.append(info.observers)
            if info.sensitivity is not None:
                sens.append(info.sensitivity)
            for p in sim.replans:
                statuses[p.status] = statuses.get(p.status, 0) + 1
            events += [f"step {info.t}: {e}" for e in info.events if not e.startswith("resampled")]
    return TrialResult(index, np.array(err2), np.array(trace), np.array(nees_pos), np.array(nees_state),
                       np.array(secs), statuses, tuple(events), np.stack(truth), np.stack(observers),
                       np.array(sens), sim.truth.collisions, np.array(level), np.array(ref),
                       sim.guidance.capped - capped)


_GUIDANCE: dict[str, Guidance] = {}  # per process: build each mission's models once (kept_guidance)


def _trial_task(mission: Mission, planner: str, index: int, seed: np.random.SeedSequence) -> TrialResult:
    """What a worker runs: one trial, reusing this process's guidance for the mission."""
    return run_trial(mission, planner, index, seed, kept_guidance(mission), on_step=_count_step)


_STEPS = None  # a worker's handle on the campaign's shared step counter (_start_worker)


def _count_step(info) -> None:
    if _STEPS is not None and info.t:  # t = 0: the reset, not a step
        with _STEPS.get_lock():
            _STEPS.value += 1


def _start_worker(parent: int, steps) -> None:
    """A local worker's initializer: count steps into ``steps`` (progress within trials)
    and exit when the process that started it is gone (killed, not only interrupted), so
    no worker outlives its campaign by more than a second."""
    global _STEPS
    _STEPS = steps
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the main process decides what an interrupt does

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(0.5)
        os._exit(1)

    threading.Thread(target=watch, daemon=True).start()


# --------------------------------------------------------------------------- trial files
def fingerprint(mission: Mission, planner: str = "") -> str:
    """SHA-256 of everything that determines a trial's result (not the trial count,
    which does not change trial k, nor where the file lives).  The baseline's trials do
    not depend on the sensor, the UAV or the ``[planner]`` settings, which it leaves out; a
    policy's do not depend on the other policies' settings (nor on which planner the
    mission file names), which it leaves out too."""
    data = asdict(_fingerprinted(mission, planner))
    if data["filter"]["plan_clusters"] == 1:  # as before the setting existed: those folders still resume
        del data["filter"]["plan_clusters"]
    if data["filter"]["loss_nats"] == 0 or planner == BASELINE:  # no loss detection (or no scans): as before
        del data["filter"]["loss_nats"], data["filter"]["reseed_share"]
    if len(data["filter"]["noise_scales"]) == 1 and data["filter"]["noise_scales"][0] == 1.0:  # one Q: as before
        del data["filter"]["noise_scales"], data["filter"]["scale_switch"]
    if len(set(data["filter"]["noise_shares"])) == 1:  # levels drawn alike: as before the setting existed
        del data["filter"]["noise_shares"]
    if data["filter"]["noise_space"] == "state":  # likewise
        del data["filter"]["noise_space"]
    if not data["filter"]["route_switch"]:  # particles that keep their cluster: as before the setting existed
        del data["filter"]["route_switch"]
    if not data["filter"]["route_probes"]:  # the first step's clusters only: as before the setting existed
        del data["filter"]["route_probes"]
    if data["filter"]["route_choice"] == "nearest":  # the nearest cluster: as before the setting existed
        del data["filter"]["route_choice"]
    if not data["filter"]["keep_out"]:  # particles that may cross obstacles: as before the setting existed
        del data["filter"]["keep_out"]
    if data["filter"]["motion"] == "replan":  # re-planned every step: as before the setting existed
        del data["filter"]["motion"]
    else:  # committed plans: the first step's clusters are a reference cloud's, not each trial's own
        data["filter"]["first_clusters"] = "reference"
    if data["guidance"]["terminal"] == "soft":  # likewise
        del data["guidance"]["terminal"]
    if not data["guidance"]["link"]:  # P1 without the link term: as before
        del data["guidance"]["link"]
    if data.get("sensor"):  # the sensor's world is the mission's, hashed once; no line of sight: as before
        del data["sensor"]["world"]
        if not data["sensor"]["line_of_sight"]:
            del data["sensor"]["line_of_sight"]
    if data["world"]["prisms"] is None:  # a world of cuboids, as before prisms existed
        del data["world"]["prisms"]
    return hashlib.sha256(json.dumps(data, default=_plain, sort_keys=True).encode()).hexdigest()


def _plain(o):
    return o.tolist() if isinstance(o, np.ndarray) else str(o)


def settings(mission: Mission, planner: str = "") -> dict[str, object]:
    """What :func:`fingerprint` hashes, flat and readable: ``{"sensor.clutter_rate": 1.0,
    "targets[0].mean0": [...], ...}``, a setting under its file key and unit where it has
    one (``sigma_deg``), else under its field's name.  The manifest keeps it, so that a
    folder holding another campaign can say what differs (:func:`held`)."""
    out: dict[str, object] = {}

    def walk(obj, key: str) -> None:
        if is_dataclass(obj):
            for f in fields(obj):
                spec = f.metadata.get("setting")
                value = getattr(obj, f.name)
                walk(file_value(spec, value) if spec else value, f"{key}.{spec.key if spec else f.name}".lstrip("."))
        elif isinstance(obj, (list, tuple)) and obj and all(is_dataclass(o) for o in obj):
            for i, o in enumerate(obj):
                walk(o, f"{key}[{i}]")
        else:
            out[key] = json.loads(json.dumps(obj, default=_plain))

    walk(_fingerprinted(mission, planner), "")
    return {k: v for k, v in out.items() if k not in ("path", "world_path", "trials")}  # not hashed: blanked


def _fingerprinted(mission: Mission, planner: str) -> Mission:
    """``mission`` less what does not change a trial of ``planner`` (see :func:`fingerprint`)."""
    mission = replace(mission, trials=0, path=Path("."), world_path=Path("."))
    if planner == BASELINE:
        mission = replace(mission, sensor=None, uav=None, planner=None, description="")
    elif mission.planner is not None:
        own = mission.planner
        mission = replace(mission, planner=replace(
            own, name=planner, manoeuvres=own.manoeuvres if planner in MANOEUVRES else None,
            fixed_sensors=own.fixed_sensors if planner == "fixed-sensors" else None,
            lookahead=own.lookahead if planner == "lookahead" else None))
    return mission


NUMBERS = ("err2", "trace", "nees_pos", "nees_state", "seconds", "truth", "observers", "sensitivity", "level",
           "nees_ref")


def _not_finite(r: TrialResult) -> list[str]:
    return [name for name in NUMBERS if getattr(r, name) is not None and not np.isfinite(getattr(r, name)).all()]


def save_trial(folder: Path, r: TrialResult, key: str) -> None:
    """Write trial ``r`` of the campaign of :func:`trial_key` ``key`` to ``folder`` (atomically).

    Raises
    ------
    CampaignFailed when the trial holds a value that is not finite (a defect: nothing
    non-finite is ever written or summed).
    """
    bad = _not_finite(r)
    if bad:
        raise CampaignFailed(f"trial {r.index} produced values that are not finite ({', '.join(bad)}); it was not "
                             "written: this is a defect of uavsim, please report it with the mission and the seed")
    buf = io.BytesIO()
    meta = np.array(json.dumps({"statuses": r.statuses, "events": list(r.events), "collisions": r.collisions,
                                "wall_capped": r.wall_capped, "trial_key": key, "format": FORMAT}))
    np.savez(buf, index=r.index, err2=r.err2, trace=r.trace, nees_pos=r.nees_pos, nees_state=r.nees_state,
             seconds=r.seconds, truth=r.truth, observers=r.observers,
             sensitivity=r.sensitivity, level=r.level, meta=meta,
             **({} if r.nees_ref is None else {"nees_ref": r.nees_ref}))
    write_atomic(folder / f"trial-{r.index:05d}.npz", buf.getvalue())


class _Unusable(Exception):
    """Why a trial file cannot be summed."""


def _read_trial(path: Path, k: int, key: str | None) -> TrialResult:
    """Trial ``k`` from ``path``, checked: readable, holding trial ``k`` of the campaign of
    :func:`trial_key` ``key`` (unchecked when None), every number finite; else :class:`_Unusable`."""
    try:
        with np.load(path) as z:
            meta = json.loads(str(z["meta"]))
            r = TrialResult(int(z["index"]), z["err2"], z["trace"], z["nees_pos"], z["nees_state"],
                            z["seconds"], meta["statuses"], tuple(meta["events"]), z["truth"],
                            z["observers"], z["sensitivity"], meta.get("collisions", 0), z["level"],
                            z["nees_ref"] if "nees_ref" in z.files else None, meta.get("wall_capped", 0))
    except Exception as exc:  # noqa: BLE001 (a damaged zip or array raises any of a dozen types, e.g.
        # NotImplementedError for a flipped version byte, found by the random-damage test)
        raise _Unusable(f"not a readable trial file ({type(exc).__name__}: {exc})") from None
    if r.index != k:
        raise _Unusable(f"holds trial {r.index}, not trial {k} as its name says")
    if key is not None and meta.get("trial_key") != key:
        raise _Unusable("written by another campaign (its key is not this campaign's)")
    try:
        bad = _not_finite(r)
    except TypeError:  # numbers that are not numbers
        bad = ["its arrays"]
    if bad:
        raise _Unusable(f"holds values that are not finite ({', '.join(bad)})")
    return r


def load_trials(folder: Path, indices: range, key: str | None = None, set_aside: bool = False
                ) -> dict[int, TrialResult]:
    """The finished trials among ``indices`` in the trials folder ``folder``, each checked
    (:func:`_read_trial`) against the :func:`trial_key` ``key`` (default: the one its
    campaign's ``campaign.json`` holds).  A file that fails the check is never returned: with
    ``set_aside``, it is moved to ``set-aside/`` beside ``folder`` with a
    :class:`CampaignWarning` saying which and why (its trial then runs again).

    Raises
    ------
    CampaignError for a file that fails the check when not ``set_aside`` (it names the
    file and why), or a folder without a readable ``campaign.json`` when ``key`` is None.
    """
    folder = Path(folder)
    if key is None:
        key = _manifest_key(folder.parent)
    out = {}
    for k in indices:
        path = folder / f"trial-{k:05d}.npz"
        if not path.exists():
            continue
        try:
            out[k] = _read_trial(path, k, key)
        except _Unusable as exc:
            if not set_aside:
                raise CampaignError(f"{path}: {exc}; delete it to run that trial again") from None
            where = _put_aside(path)
            warnings.warn(f"{path}: {exc}; moved to {where} and not summed: trial {k} runs again",
                          CampaignWarning, stacklevel=2)
    return out


def _manifest_key(out: Path) -> str:
    try:
        key = json.loads((out / "campaign.json").read_text()).get("trial_key")
    except (OSError, ValueError, AttributeError):
        key = None
    if not isinstance(key, str):
        raise CampaignError(f"{out / 'campaign.json'}: missing or not a campaign manifest, so nothing says which "
                            "campaign the trial files belong to")
    return key


def _put_aside(path: Path) -> Path:
    """Move ``path`` into ``set-aside/`` beside its folder (never over another file)."""
    shelf = path.parent.parent / "set-aside"
    shelf.mkdir(exist_ok=True)
    where, n = shelf / path.name, 1
    while where.exists():
        where, n = shelf / f"{path.stem}.{n}{path.suffix}", n + 1
    os.replace(path, where)
    return where


def _prepare_folder(out: Path, mission: Mission, planner: str, resume: bool) -> Path:
    """Create or check ``out``; returns its trials folder.

    Raises
    ------
    CampaignError when ``out`` cannot hold the campaign (a file where a folder must be,
    no permission, a manifest that is not one) or holds another campaign.
    """
    try:
        return _prepare(out, mission, planner, resume)
    except OSError as exc:
        raise CampaignError(f"{out}: cannot use this folder: {exc.filename or out}: {exc.strerror or exc}") from None


def _manifest(mission: Mission, planner: str) -> dict:
    return {"mission": str(mission.path), "planner": planner, "steps": mission.steps, "seed": mission.seed,
            "fingerprint": fingerprint(mission, planner), "trial_key": trial_key(mission, planner), "format": FORMAT,
            "settings": settings(mission, planner)}


def trial_key(mission: Mission, planner: str) -> str:
    """What every trial file of a campaign carries and is checked against: the
    fingerprint less the :data:`COSMETIC` settings (a reworded description keeps the
    campaign's trials, as it keeps its folder)."""
    return fingerprint(replace(mission, description=""), planner)


COMPARED = ("planner", "steps", "seed", "fingerprint")  # manifest keys that must match to resume
#: Settings hashed into the fingerprint that change no trial: a folder whose manifest
#: differs from this run only in them holds this run's campaign (a mission whose
#: description was reworded keeps its folders).
COSMETIC = frozenset({"description"})


def _existing(out: Path) -> tuple[dict, list[Path]] | None:
    """The manifest of ``out`` and its trial files; None when it holds no finished trial
    (nothing to protect).  CampaignError when the folder cannot be a campaign's."""
    trials, path = out / "trials", out / "campaign.json"
    if trials.exists() and not trials.is_dir():
        raise CampaignError(f"{trials} is a file, but the campaign keeps its trials in a folder of that name")
    files = list(trials.glob("trial-*.npz"))
    if not files:
        return None
    if not path.exists():  # no manifest, no reuse: nothing says whose trials these are
        return {}, files
    try:
        old = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError):
        raise CampaignError(f"{path} is not a campaign manifest (not JSON); use another --out") from None
    if not isinstance(old, dict):
        raise CampaignError(f"{path} is not a campaign manifest; use another --out")
    return old, files


def _difference(old: dict, new: dict) -> str:
    """What differs between the manifest ``old`` and this run's ``new`` ("" if nothing)."""
    if not old:
        return "no campaign.json says which campaign its trial files belong to"
    if old.get("format") != FORMAT:
        return (f"trials written by another uavsim version: trial format {old.get('format', 1)}, "
                f"this one writes {FORMAT}")
    if all(old.get(k) == new[k] for k in COMPARED):
        return ""
    if isinstance(old.get("settings"), dict) and all(old.get(k) == new[k] for k in COMPARED if k != "fingerprint"):
        a, b = old["settings"], new["settings"]
        if {k for k in {*a, *b} if a.get(k, "(none)") != b.get(k, "(none)")} <= COSMETIC:
            return ""

    def shown(v) -> str:
        text = v if isinstance(v, str) else json.dumps(v)
        return text if len(text) <= 24 else text[:21] + "..."

    if old.get("planner") != new["planner"]:
        return f"planner {shown(new['planner'])} in this run, {shown(old.get('planner'))} there"
    if isinstance(old.get("settings"), dict):
        a, b = old["settings"], new["settings"]
        keys = [k for k in dict.fromkeys([*b, *a]) if a.get(k, "(none)") != b.get(k, "(none)")]
        parts = [f"{k} {shown(b.get(k))} in this run, {shown(a.get(k))} there" for k in keys[:3]]
        if parts:
            return "; ".join(parts) + (f" and {len(keys) - 3} more" if len(keys) > 3 else "")
    parts = [f"{k} {shown(new[k])} in this run, {shown(old.get(k))} there" for k in ("seed", "steps")
             if old.get(k) != new[k]]
    return "; ".join(parts) or f"the settings of mission {old.get('mission')} or its world differ"


@dataclass(frozen=True)
class Held:
    """What an output folder holds before a campaign runs there (:func:`held`).

    ``done``: finished trials this run can use (of its trials 0..n-1; every trial file
    when the folder holds another campaign); ``differs``: "" when the folder holds this
    very campaign (same mission settings, planner, seed, steps: only the trial count may
    differ), else what differs, e.g. ``seed 99 in this run, 2023 there``; ``files``:
    every trial file it holds."""

    done: int
    differs: str
    files: int = 0


def held(out: Path, mission: Mission, planner: str) -> Held | None:
    """What ``out`` holds for a campaign of ``mission`` with ``planner``: None when it holds
    no finished trial (the campaign starts afresh there), else a :class:`Held`.

    Raises
    ------
    CampaignError when ``out`` cannot hold a campaign (see :func:`run_campaign`).
    """
    try:
        found = _existing(Path(out))
    except OSError as exc:
        raise CampaignError(f"{out}: cannot use this folder: {exc.filename or out}: {exc.strerror or exc}") from None
    if found is None:
        return None
    old, files = found
    differs = _difference(old, _manifest(mission, planner))
    indices = {int(f.stem[6:]) for f in files if f.stem[6:].isdigit()}
    return Held(len(files) if differs else sum(k < mission.trials for k in indices), differs, len(files))


LOCK = "campaign.lock"  # in a campaign folder: held by the process writing it
_LOCKS: dict[Path, list] = {}  # the campaign locks this process holds: lock path -> [open file, depth]


@contextmanager
def campaign_lock(out: Path):
    """Hold the lock of the campaign folder ``out`` while a block writes it: an OS file
    lock on ``out/campaign.lock`` (``flock``: the kernel releases it when this process
    ends, however it ends, a SIGKILL included) holding the holder's PID.  Re-entrant within
    a process.  Where the OS has no ``flock`` (Windows), nothing is locked.

    Raises
    ------
    CampaignError when another process holds it (naming that process), or ``out`` cannot
    be made.
    """
    path = Path(os.path.abspath(Path(out) / LOCK))
    if path in _LOCKS or fcntl is None:
        if path in _LOCKS:
            _LOCKS[path][1] += 1
        try:
            yield
        finally:
            if path in _LOCKS:
                _LOCKS[path][1] -= 1
        return
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fh = open(path, "a+")
    except OSError as exc:
        raise CampaignError(f"{out}: cannot use this folder: {exc.filename or out}: {exc.strerror or exc}") from None
    try:
        fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        fh.seek(0)
        holder = fh.read().strip() or "unknown"
        fh.close()
        raise CampaignError(f"{out} is in use: another uavsim run (process {holder}) is writing its campaign there; "
                            "wait for it to end, or choose another --out") from None
    fh.seek(0)
    fh.truncate()
    fh.write(f"{os.getpid()}\n")
    fh.flush()
    _LOCKS[path] = [fh, 1]
    try:
        yield
    finally:
        _LOCKS[path][1] -= 1
        if not _LOCKS[path][1]:
            del _LOCKS[path]
            fcntl.flock(fh, fcntl.LOCK_UN)
            fh.close()


def clear(out: Path) -> None:
    """Delete the campaign ``out`` holds: its manifest and trial files (nothing else)."""
    for path in [Path(out) / "campaign.json", *(Path(out) / "trials").glob("trial-*.npz"),
                 *(Path(out) / "trials").glob(".trial-*.tmp")]:
        path.unlink(missing_ok=True)


def _prepare(out: Path, mission: Mission, planner: str, resume: bool) -> Path:
    trials, path = out / "trials", out / "campaign.json"
    manifest = _manifest(mission, planner)
    found = _existing(out)
    if found is not None:
        old, files = found
        differs = _difference(old, manifest)
        if differs:
            raise CampaignError(f"{out} holds a different campaign ({differs}): use another --out")
        if not resume:
            raise CampaignError(f"{out} already holds a campaign ({len(files)} trials done): pass --resume to "
                                "continue it, or choose another --out")
    trials.mkdir(parents=True, exist_ok=True)
    for stale in trials.glob(".trial-*.tmp"):  # a writer killed before its rename
        stale.unlink()
    write_atomic(path, json.dumps(manifest, indent=1).encode())
    return trials


# --------------------------------------------------------------------------- the campaign
CONNECT_SECONDS = 20.0  # a Dask scheduler must answer within this
NO_WORKER_SECONDS = 120.0  # a Dask cluster with no worker for this long ends the campaign


class _ClusterLost(Exception):
    """A cluster that cannot finish the campaign (what ended it)."""


@dataclass
class _Runner:
    """Where the trials run: a ``concurrent.futures`` executor (None: in this process),
    ``close(abort)`` (at once, workers terminated, when ``abort``), how many trials to keep
    in flight (twice the worker threads), ``check()`` called about every second while
    waiting (raises :class:`_ClusterLost` for a cluster that cannot finish),
    ``died()`` saying how a local worker ended when the pool broke, and ``submit`` (the
    executor's)."""

    executor: object = None
    close: object = lambda abort=False: None
    window: int = 0
    check: object = lambda: None
    died: object = lambda: "ended"
    submit: object = None

    def __post_init__(self):
        if self.submit is None and self.executor is not None:
            self.submit = self.executor.submit


def _executor(workers: int, scheduler: str | None, steps=None) -> _Runner:
    """The :class:`_Runner` for ``workers`` local processes or a Dask ``scheduler``.
    ``steps``: a shared counter the local workers add their steps to."""
    if scheduler:
        return _dask(scheduler)
    if workers > 1:
        pool = ProcessPoolExecutor(max_workers=workers, mp_context=get_context("spawn"), initializer=_start_worker,
                                   initargs=(os.getpid(), steps))
        processes = {}

        def close(abort: bool = False) -> None:
            if abort:  # an interrupt: the finished trials are on disk; the running ones are dropped
                for process in list((pool._processes or {}).values()):
                    process.terminate()
            pool.shutdown(wait=not abort, cancel_futures=True)

        def submit(*args):
            future = pool.submit(*args)
            processes.update(pool._processes or {})  # kept to say how one ended if the pool breaks
            return future

        def died() -> str:
            deadline = time.monotonic() + 3.0  # the dead one is being reaped (by the pool's thread, maybe),
            while time.monotonic() < deadline and any(p.exitcode is None for p in processes.values()):
                time.sleep(0.05)  # and the pool is ending the others
            codes = [p.exitcode for p in processes.values() if p.exitcode is not None and p.exitcode != 0]
            killed = [c for c in codes if c != -signal.SIGTERM] or codes  # the pool ends the others by SIGTERM
            if not killed:
                return "ended"
            code = killed[0]
            if code < 0:
                name = signal.Signals(-code).name
                return f"was killed by {name}" + (" (as the out-of-memory killer does)" if name == "SIGKILL" else "")
            return f"exited with status {code}"

        return _Runner(pool, close, 2 * workers, died=died, submit=submit)
    return _Runner()


def _connect(client_class, scheduler: str):
    """``(client, threads)`` of the Dask scheduler at ``scheduler``, or CampaignError when
    none answers within :data:`CONNECT_SECONDS`.  The client is made in a thread of its own
    and waited for: Dask's own ``timeout`` does not bound the handshake with a listener
    that does not speak its protocol (that thread is left behind, idle)."""
    got: list = []

    def connect() -> None:
        try:
            client = client_class(scheduler, timeout=CONNECT_SECONDS)
            got.append((client, sum(client.nthreads(callback_timeout=CONNECT_SECONDS).values())))
        except Exception as exc:  # noqa: BLE001 (reported below, whatever it is)
            got.append(exc)

    thread = threading.Thread(target=connect, daemon=True, name="uavsim-dask-connect")
    thread.start()
    thread.join(CONNECT_SECONDS + 1.0)
    if not got:
        raise CampaignError(f"--scheduler {scheduler}: no Dask scheduler answered within {CONNECT_SECONDS:.0f} s")
    if isinstance(got[0], Exception):
        raise CampaignError(f"--scheduler {scheduler}: cannot connect ({type(got[0]).__name__}: {got[0]})")
    return got[0]


def _dask(scheduler: str) -> _Runner:
    """A Dask cluster's runner: connecting waits at most :data:`CONNECT_SECONDS`, and a
    cluster without workers for :data:`NO_WORKER_SECONDS` (or whose scheduler is gone)
    fails the campaign."""
    try:
        from distributed import Client
    except ImportError:
        raise CampaignError("--scheduler needs Dask: pip install 'uavsim[dask]'") from None
    client, threads = _connect(Client, scheduler)
    since = [time.monotonic()]

    def check() -> None:
        try:
            alive = client.status == "running" and sum(client.nthreads(callback_timeout=CONNECT_SECONDS).values())
        except (OSError, TimeoutError):
            alive = False
        if alive:
            since[0] = time.monotonic()
        elif time.monotonic() - since[0] > NO_WORKER_SECONDS:
            raise _ClusterLost(f"the Dask scheduler {scheduler} has had no worker (or not answered) for "
                                 f"{NO_WORKER_SECONDS:.0f} s")

    return _Runner(client.get_executor(), lambda abort=False: client.close(), 2 * max(threads, 1), check)


def run_campaign(mission: Mission, planner: str, out: Path | None = None, workers: int = 1,
                 scheduler: str | None = None, resume: bool = False, progress=None, record=None) -> dict:
    """All trials of ``mission`` with ``planner``; returns the summary.

    ``out``: keep every finished trial in ``out/trials`` (see module docstring), holding
    the folder's lock (:func:`campaign_lock`) meanwhile; ``workers``: local processes (1
    runs here); ``scheduler``: a Dask scheduler address; ``progress``: a
    :class:`uavsim.progress.Progress`-like object (``start``, ``advance``, ``close``);
    ``record = (path, trial, particles)``: write that trial to a rerun file (it runs in
    this process).

    Raises
    ------
    CampaignError for a folder or request that cannot be used; CampaignFailed when the
    campaign cannot finish (a worker died, the cluster lost its workers): the message
    says which trials were running; the finished ones are kept in ``out``.
    """
    with mission_errors(mission.path):
        make_policy(planner, mission)  # a setting this policy cannot use is refused before any trial
    if out is None:
        return _run(mission, planner, None, workers, scheduler, resume, progress, record)
    with campaign_lock(out):
        return _run(mission, planner, Path(out), workers, scheduler, resume, progress, record)


def _run(mission, planner, out, workers, scheduler, resume, progress, record) -> dict:
    t0 = time.perf_counter()
    seeds = trial_seeds(mission.seed, mission.trials)
    key = trial_key(mission, planner)
    folder = _prepare_folder(out, mission, planner, resume) if out is not None else None
    # With a folder the trials live on disk (checked here, damaged or foreign files set
    # aside, and read back for the summary), not in memory: the campaign's memory does
    # not grow with its trial count.
    done = set(load_trials(folder, range(mission.trials), key, set_aside=True)) if folder is not None else set()
    results: dict[int, TrialResult] = {}
    todo = [k for k in range(mission.trials) if k not in done]
    if progress:
        progress.start(mission.trials, len(done), mission.steps)

    def finished(r: TrialResult) -> None:
        if folder is not None:
            save_trial(folder, r, key)
        else:
            results[r.index] = r
        if progress:
            progress.advance()

    if record is not None:
        finished(_recorded_trial(mission, planner, seeds, record))
        todo = [k for k in todo if k != record[1]]
    steps = get_context("spawn").Value("q", 0) if todo and workers > 1 and not scheduler else None
    runner = _executor(min(workers, max(len(todo), 1)), scheduler, steps) if todo else _Runner()
    aborted, running = True, {}
    try:
        if runner.executor is None:
            guidance = kept_guidance(mission) if todo else None
            step = (lambda info: info.t and progress.step()) if progress and hasattr(progress, "step") else None
            for k in todo:
                finished(run_trial(mission, planner, k, seeds[k], guidance, on_step=step))
        else:  # at most `window` trials in flight: the executor holds no more than that

            def drain(until) -> None:
                while True:
                    over, _ = wait(set(running), timeout=1.0, return_when=until)
                    for future in over:
                        finished(future.result())
                        del running[future]
                    if steps is not None and progress and hasattr(progress, "steps"):
                        progress.steps(steps.value)
                    runner.check()
                    if over and until == FIRST_COMPLETED or not running:
                        return

            for k in todo:
                if len(running) == runner.window:
                    drain(FIRST_COMPLETED)
                running[runner.submit(_trial_task, mission, planner, k, seeds[k])] = k
            drain(ALL_COMPLETED)
        aborted = False
    except BrokenExecutor:
        lost = sorted(k for f, k in running.items() if not f.done() or f.exception() is not None)
        raise CampaignFailed(_failed(f"a worker process {runner.died()}", lost, folder)) from None
    except _ClusterLost as exc:
        raise CampaignFailed(_failed(str(exc), sorted(running.values()), folder)) from None
    finally:
        runner.close(aborted)
        if progress:
            progress.close()
    if folder is not None:  # the summary comes from what is on disk
        results = load_trials(folder, range(mission.trials), key, set_aside=True)
        if len(results) < mission.trials:
            raise CampaignFailed(_failed("trial files were damaged during the run", [], folder))
    return summarize(mission, planner, list(results.values()), time.perf_counter() - t0)


def _failed(what: str, lost: list[int], folder: Path | None) -> str:
    """One line: what ended the campaign, the trials it lost, what is kept and how to go on."""
    running = f" while trial{'s' * (len(lost) > 1)} {', '.join(map(str, lost))} ran" if lost else ""
    if folder is None:
        return f"{what}{running}; the campaign has no output folder, so its finished trials are lost"
    n = len(list(folder.glob("trial-*.npz")))
    return (f"{what}{running}; the {n} finished trials are kept in {folder.parent}: run the same command again "
            "to resume")


def _recorded_trial(mission, planner, seeds, record) -> TrialResult:
    from .recording import Recorder, RecordingError

    path, k, particles = record
    try:
        recorder = Recorder(path, mission, planner, k, particles=particles)
        try:
            result = run_trial(mission, planner, k, seeds[k], on_step=recorder)
        finally:
            recorder.close()
    except RecordingError as exc:
        raise CampaignFailed(f"--record {exc}; stopped before the other trials: run again with another "
                             "--record, or without it") from None
    return result


def summarize(mission: Mission, planner: str, results: list[TrialResult], wall: float) -> dict:
    """The campaign summary (JSON-ready): RMSE per step and target, per-trial mean squared
    errors, NEES consistency, the PCRLB of the flown paths (:mod:`.bounds.pcrlb`), timing,
    statuses."""
    results = sorted(results, key=lambda r: r.index)
    err2 = np.stack([r.err2 for r in results])  # (trials, steps, M)
    per_target = metrics.rmse_per_target(err2)  # (M, steps)
    rmse = per_target.mean(axis=0)
    secs = np.concatenate([r.seconds for r in results])
    statuses: dict[str, int] = {}
    for r in results:
        for k, v in r.statuses.items():
            statuses[k] = statuses.get(k, 0) + v
    sensor = make_policy(planner, mission).sensor  # the fixed sensors carry their own
    prior = bound_prior(mission)
    bound = accuracy_floor(mission, sensor or mission.sensor, results, prior)
    return {
        "mission": str(mission.path), "planner": planner, "trials": len(results), "steps": mission.steps,
        "seed": mission.seed, "truth": mission.truth,
        "clutter_rate": None if sensor is None else sensor.clutter_rate,
        "filter": mission.filter.kind,
        "particles": mission.filter.particles if mission.filter.kind == "particle" else None,
        "targets": [t.name for t in mission.targets],
        "rmse": rmse.tolist(), "rmse_per_target": per_target.tolist(), "time_avg_rmse": float(rmse.mean()),
        "time_avg_rmse_per_target": per_target.mean(axis=1).tolist(),
        "trial_mse": err2.mean(axis=(1, 2)).tolist(),
        "final_error": np.sqrt(err2[:, -1]).tolist(),  # (trials, M) position error at the last step
        "pcrlb_pos": None if bound is None else bound.pos.tolist(),
        "pcrlb_pos_per_target": None if bound is None else bound.pos_per_target.tolist(),
        "time_avg_pcrlb": None if bound is None else float(bound.pos.mean()),
        "pcrlb_q2": None if bound is None else bound.q2,
        **_bound_errors(mission, bound, err2, prior),
        "mean_trace": np.stack([r.trace for r in results]).mean(axis=0).T.tolist(),
        "nees": {"pos": metrics.consistency(np.stack([r.nees_pos for r in results]), len(metrics.POS),
                                            reference=_stack_reference(results)),
                 "state": metrics.consistency(np.stack([r.nees_state for r in results]), len(metrics.STATE))},
        "calibration": metrics.calibration(np.stack([r.level for r in results])),
        "guidance_status": dict(sorted(statuses.items())),
        "events": sum(len(r.events) for r in results),
        "track_loss_events": track_loss_events([t.name for t in mission.targets], results),
        "occluded_per_target": occluded_share(sensor, results),
        "truth_collisions": sum(r.collisions for r in results),
        "wall_capped": [r.wall_capped for r in results],  # per trial: plans the wall clock stopped
        "timing": {k: float(np.median(secs[:, i])) for i, k in enumerate(STAGES)},
        "wall_seconds": wall,
    }


def _stack_reference(results: list[TrialResult]) -> np.ndarray | None:
    """``(trials, steps, M, draws)`` the calibrated reference NEES of every trial, None if
    a trial file lacks it."""
    if any(r.nees_ref is None for r in results):
        return None
    return np.stack([r.nees_ref for r in results])


def occluded_share(sensor, results: list[TrialResult]) -> list[float] | None:
    """``(M,)`` each target's share of (trial, step, sensor) lines of sight a building
    blocked, from the trials' truths and observers; None without line of sight or sensors."""
    if sensor is None or not sensor.line_of_sight or results[0].observers.shape[1] == 0:
        return None
    truth, obs = np.stack([r.truth for r in results]), np.stack([r.observers for r in results])
    seen = sensor.visible(truth[..., :, None, :3], obs[..., None, :, :3])  # (trials, T, M, S)
    return (~seen).mean(axis=(0, 1, 3)).tolist()


def track_loss_events(names: list[str], results: list[TrialResult]) -> list[int]:
    """``(M,)`` how often each target's track was declared lost and re-seeded over the
    trials (the events of :meth:`uavsim.sim.Simulation._recover`)."""
    counts = dict.fromkeys(names, 0)
    for r in results:
        for e in r.events:
            name, _, rest = e.partition(": ")[2].partition(": ")
            if rest.startswith("track lost") and name in counts:
                counts[name] += 1
    return list(counts.values())


def _bound_errors(mission: Mission, bound: Bound | None, err2: np.ndarray, prior) -> dict:
    """What qualifies the PCRLB: its Monte-Carlo standard errors (jackknife over the
    trials) per step of ``pcrlb_pos`` and of ``time_avg_pcrlb``, None with one trial or
    no bound; each target's share of the prior its true start may come from
    (:func:`.truth.bound_prior`); and the check of the bound against the RMSE, target by target
    (:func:`bound_margins`; named targets only from :data:`BOUND_CHECK_TRIALS` trials on)."""
    se = None if bound is None else bound.standard_error()
    margin, margin_se = bound_margins(err2, bound) if se is not None else (None, None)
    return {"pcrlb_pos_se": None if se is None else se.tolist(),
            "time_avg_pcrlb_se": None if se is None else float(bound.standard_error(lambda p: p.mean(axis=(-2, -1)))),
            "pcrlb_start_acceptance": None if bound is None else prior[0].tolist(),
            "pcrlb_margin_per_target": None if margin is None else margin.tolist(),
            "pcrlb_margin_se": None if margin is None else margin_se.tolist(),
            "pcrlb_beaten": None if margin is None or len(err2) < BOUND_CHECK_TRIALS else
            [t.name for t, d, s in zip(mission.targets, margin, margin_se) if d < -2.0 * s]}


BOUND_CHECK_TRIALS = 10  # fewer trials: the plug-in bound is biased up and its s.e. too rough to judge it


def bound_margins(err2: np.ndarray, bound: Bound) -> tuple[np.ndarray, np.ndarray]:
    """``(margin, se)``, each ``(M,)``: per target the time-averaged RMSE less the
    time-averaged bound, and its jackknife standard error over the trials (the RMSE and
    the bound left out together, since both average the same trials).  A bound is beaten
    beyond its Monte-Carlo error where ``margin < -2 se``.

    Parameters
    ----------
    err2 : (trials, T, M) squared position errors; bound : the PCRLB of the same trials,
    with its leave-one-out bounds (two trials or more).
    """
    n = len(err2)
    margin = (metrics.rmse_per_target(err2) - bound.pos_per_target).mean(axis=-1)
    rmse_loo = np.sqrt((err2.sum(axis=0) - err2) / (n - 1))  # (n, T, M)
    loo = (np.swapaxes(rmse_loo, 1, 2) - bound.left_out).mean(axis=-1)  # (n, M)
    return margin, jackknife_se(loo)


def accuracy_floor(mission: Mission, sensor, results: list[TrialResult], prior=None) -> Bound | None:
    """The PCRLB of the campaign's trials (:func:`.bounds.pcrlb.pcrlb_planned`) from the
    prior the true starts are drawn from (``prior``, else :func:`.truth.bound_prior`), or None for
    a stochastic truth, whose bound is not built (see :mod:`.bounds.pcrlb`)."""
    if mission.truth != "planned":
        return None
    cov0 = (prior or bound_prior(mission))[1]
    return pcrlb_planned(np.stack([r.sensitivity for r in results]), np.stack([r.truth for r in results]),
                         np.stack([r.observers for r in results]), cov0, sensor)


def with_baseline(summary: dict, base: dict) -> dict:
    """``summary`` with the no-information baseline of the same trials beside it:
    its RMSE curve, the ratios policy / baseline of the time-averaged RMSE over all
    steps and over the second half, and the paired t of the per-trial mean squared
    errors (positive: the policy is better)."""
    if base["trial_mse"] and len(base["trial_mse"]) != len(summary["trial_mse"]):
        raise ValueError("the baseline must run the same trials as the policy it is compared with")
    half = len(summary["rmse"]) // 2
    ratio_half = float(np.mean(summary["rmse"][half:]) / np.mean(base["rmse"][half:]))
    block = {"rmse": base["rmse"], "rmse_per_target": base["rmse_per_target"], "time_avg_rmse": base["time_avg_rmse"],
             "ratio": summary["time_avg_rmse"] / base["time_avg_rmse"], "ratio_second_half": ratio_half,
             "paired_t": metrics.paired_t(summary["trial_mse"], base["trial_mse"]),
             "nees_pos_inside": base["nees"]["pos"]["inside"],
             "ratio_per_target": (np.array(summary["time_avg_rmse_per_target"])
                                  / np.array(base["time_avg_rmse_per_target"])).tolist(),
             **track_losses(summary["final_error"], base["time_avg_rmse_per_target"])}
    return {**summary, "baseline": block}


LOST_FACTOR = 3.0  # a target-trial is lost when its final error exceeds this many no-information RMSEs


def track_losses(final: list, base_rmse: list) -> dict:
    """Lost tracks: target-trials whose last-step position error is more than
    :data:`LOST_FACTOR` times the target's no-information RMSE (the prediction alone,
    averaged over the trials and steps).  Not the same trial's last-step error with no
    information: a target that reaches its goal takes the prediction there too (on the
    paper mission T4's is 0.0-0.2 m), so that yardstick calls every track of it lost.

    Parameters
    ----------
    final : (trials, M) last-step position errors; base_rmse : (M,) time-averaged RMSE of
    the no-information baseline on the same trials.

    Returns
    -------
    ``lost_per_target`` (M,) counts and ``lost_share`` over all target-trials.
    """
    lost = np.asarray(final, float) > LOST_FACTOR * np.asarray(base_rmse, float)
    return {"lost_per_target": lost.sum(axis=0).tolist(), "lost_share": float(lost.mean())}
