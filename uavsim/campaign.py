"""Monte-Carlo campaigns: trials, their seeds, and the metrics of Sec. VI-B.

Trial k of a campaign with seed S runs on ``SeedSequence(S).spawn(trials)[k]``, so its
result does not depend on how many trials run, in which order, or where.

RMSE (Sec. VI-B): at step t, ``eps_t = sqrt(mean_n |x^pos_hat_t(n) - x^pos_t(n)|^2)`` over
the N trials, with (x, y) positions; ``rmse`` averages it over targets.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from .config import Mission
from .guidance import Guidance
from .sim import STAGES, Simulation


@dataclass(frozen=True)
class TrialResult:
    """One trial's record: squared (x, y) errors ``(steps, M)``, covariance traces
    ``(steps, M)``, stage seconds ``(steps, len(STAGES))``, guidance statuses, events."""

    index: int
    err2: np.ndarray
    trace: np.ndarray
    seconds: np.ndarray
    statuses: dict[str, int]
    events: tuple[str, ...]


def with_overrides(mission: Mission, steps=None, trials=None, seed=None, clutter_rate=None) -> Mission:
    """The mission with command-line overrides applied (None keeps the file's value)."""
    m = mission
    if clutter_rate is not None:
        m = replace(m, sensor=replace(m.sensor, clutter_rate=clutter_rate))
    return replace(m, steps=steps or m.steps, trials=trials or m.trials, seed=m.seed if seed is None else seed)


def trial_seeds(seed: int, trials: int) -> list[np.random.SeedSequence]:
    return np.random.SeedSequence(seed).spawn(trials)


def run_trial(mission: Mission, planner: str, index: int, seed: np.random.SeedSequence,
              guidance: Guidance | None = None, on_step=None) -> TrialResult:
    """Run one trial; ``on_step(info)`` sees every step (recording)."""
    sim = Simulation(mission, planner, guidance)
    info = sim.reset(seed)
    if on_step:
        on_step(info)
    err2, trace, secs, statuses, events = [], [], [], {}, []
    for _ in range(mission.steps):
        info = sim.step()
        if on_step:
            on_step(info)
        err2.append(((info.mean[:, :2] - info.truth[:, :2]) ** 2).sum(axis=1))
        trace.append(np.trace(info.cov, axis1=1, axis2=2))
        secs.append([info.seconds[k] for k in STAGES])
        for p in info.plans:
            statuses[p.status] = statuses.get(p.status, 0) + 1
        events += [f"step {info.t}: {e}" for e in info.events if not e.startswith("resampled")]
    return TrialResult(index, np.array(err2), np.array(trace), np.array(secs), statuses, tuple(events))


def summarize(mission: Mission, planner: str, results: list[TrialResult], wall: float) -> dict:
    """The campaign summary (JSON-ready): RMSE per step and target, timing, statuses."""
    results = sorted(results, key=lambda r: r.index)
    err2 = np.stack([r.err2 for r in results])  # (trials, steps, M)
    per_target = np.sqrt(err2.mean(axis=0)).T  # (M, steps)
    rmse = per_target.mean(axis=0)
    secs = np.concatenate([r.seconds for r in results])
    statuses: dict[str, int] = {}
    for r in results:
        for k, v in r.statuses.items():
            statuses[k] = statuses.get(k, 0) + v
    return {
        "mission": str(mission.path), "planner": planner, "trials": len(results), "steps": mission.steps,
        "seed": mission.seed, "truth": mission.truth, "clutter_rate": mission.sensor.clutter_rate,
        "particles": mission.filter.particles, "targets": [t.name for t in mission.targets],
        "rmse": rmse.tolist(), "rmse_per_target": per_target.tolist(), "time_avg_rmse": float(rmse.mean()),
        "time_avg_rmse_per_target": per_target.mean(axis=1).tolist(),
        "mean_trace": np.stack([r.trace for r in results]).mean(axis=0).T.tolist(),
        "timing": {k: float(np.median(secs[:, i])) for i, k in enumerate(STAGES)},
        "guidance_status": statuses,
        "events": sum(len(r.events) for r in results),
        "wall_seconds": wall,
    }


def run_campaign(mission: Mission, planner: str, progress=None, record=None) -> dict:
    """All trials of ``mission`` with ``planner``, in this process; returns the summary.

    ``record = (path, trial, particles)`` writes that trial to a rerun file.
    """
    t0 = time.perf_counter()
    guidance = Guidance(mission.world, mission.dynamics, mission.guidance)
    results = []
    for k, seed in enumerate(trial_seeds(mission.seed, mission.trials)):
        recorder = None
        if record is not None and record[1] == k:
            from .recording import Recorder

            recorder = Recorder(record[0], mission, planner, k, particles=record[2])
        try:
            results.append(run_trial(mission, planner, k, seed, guidance, on_step=recorder))
        finally:
            if recorder is not None:
                recorder.close()
        if progress:
            progress(k + 1, mission.trials)
    return summarize(mission, planner, results, time.perf_counter() - t0)
