"""Store the particle filter's outputs on fixed seeds in ``filter_reference.npz``.

    python tests/data/make_filter_reference.py

The file was written ONCE with the implementation of commit 8c473d3 (``uavsim/filtering.py``,
before the particle filter's speed-ups from commit f09163a on), so
``tests/test_filter_reference.py`` checks that later implementations compute the same
numbers.  Do not regenerate it to make a test pass; regenerate only when the numbers are
meant to change, and say so in the commit.

What is stored:

* ``lik/<case>/...``: Eq. (10) log-likelihoods for scans with empty sets, clutter-only
  sets, many false alarms, bearings across the +-pi cut, ``Lambda = 0``, ``p_D = 0`` and
  ``p_D = 1`` (inputs and outputs, so the inputs do not depend on the generator);
* ``pf/...``: a two-target filter run on its own (predict, likelihood, update,
  resampling with roughening, moments), with one degenerate update;
* ``loop/...``: one closed-loop trial of the paper mission (300 particles, 4 steps): the
  per-step means, covariances, decision scores and UAV positions, and the guidance plans
  the trial used, so the test replays them and does not depend on the guidance solver.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from uavsim.belief.particle import ParticleFilter
from uavsim.campaign import trial_seeds
from uavsim.config import load_mission
from uavsim.sensing import BearingModel, Scan, log_likelihood, observe, scan_loglik
from uavsim.sim import Simulation

HERE = Path(__file__).resolve().parent
PAPER = HERE.parents[1] / "missions" / "paper.toml"
DEG = math.pi / 180

# (name, sigma, p_D, Lambda, set sizes per channel, bearings "near" the particles or "far")
LIKELIHOOD_CASES = [
    ("paper", 1 * DEG, 0.95, 1.0, (0, 1, 3), "near"),
    ("clutter_only", 1 * DEG, 0.95, 1.0, (2, 5, 1), "far"),
    ("all_empty", 1 * DEG, 0.95, 1.0, (0, 0, 0), "near"),
    ("many_false_alarms", 1 * DEG, 0.95, 50.0, (60, 40, 0), "near"),
    ("four_hundred", 1 * DEG, 0.95, 400.0, (400, 1, 2), "near"),
    ("wrap", 1 * DEG, 0.95, 1.0, (1, 2, 3), "wrap"),
    ("no_clutter", 1 * DEG, 0.95, 0.0, (0, 1, 2), "near"),
    ("pd_one_no_clutter", 1 * DEG, 1.0, 0.0, (1, 0, 2), "near"),
    ("pd_one", 2 * DEG, 1.0, 2.5, (0, 2, 4), "near"),
    ("pd_zero", 1 * DEG, 0.0, 2.5, (2, 0, 3), "near"),
    ("tiny_sigma", 0.01 * DEG, 0.95, 1.0, (1, 2, 1), "near"),
]


def likelihood_inputs(rng, sizes, where, n=300):
    """(M, K) padded bearings and mask, (M, N) expected bearings."""
    m, k = len(sizes), max(max(sizes), 1)
    centre = np.full((m, 1), np.pi - 0.01) if where == "wrap" else rng.uniform(-3, 3, (m, 1))
    expected = np.where(rng.random((m, n)) < 0.7, centre + rng.normal(0, 0.03, (m, n)),
                        rng.uniform(-np.pi, np.pi, (m, n)))
    expected = np.angle(np.exp(1j * expected))
    bearings = rng.uniform(-np.pi, np.pi, (m, k))
    if where == "far":
        bearings = np.angle(np.exp(1j * (centre + np.pi + rng.normal(0, 0.2, (m, k)))))
    elif where == "wrap":
        bearings[:, 0] = -np.pi + 0.005
    else:
        bearings[:, 0] = centre[:, 0] + 0.02
    valid = np.arange(k)[None, :] < np.array(sizes)[:, None]
    return np.where(valid, bearings, 0.0), valid, expected


def likelihood_reference(out: dict) -> None:
    for i, (name, sigma, pd, lam, sizes, where) in enumerate(LIKELIHOOD_CASES):
        bearings, valid, expected = likelihood_inputs(np.random.default_rng(100 + i), sizes, where)
        p = f"lik/{name}/"
        out |= {p + "bearings": bearings, p + "valid": valid, p + "expected": expected,
                p + "sensor": np.array([sigma, pd, lam]),
                p + "loglik": log_likelihood(bearings, valid, expected, BearingModel(sigma, pd, lam))}


def filter_run() -> dict[str, np.ndarray]:
    """Two targets, 400 particles, 6 steps from a fixed observer; step 3 is a missed
    detection under p_D = 1 for target 1 (degenerate, skipped).  Per-step arrays
    ``(6, ...)`` and the final particles and log-weights (the test reruns this)."""
    rng = np.random.default_rng(7)
    m = load_mission(PAPER)
    dyn = m.dynamics
    means0 = np.array([[300.0, 700, 0, 5, -5, 0], [820, 610, 0, -3, -8, 0]])
    covs0 = np.tile(np.diag([200.0, 200, 1e-10, 20, 20, 1e-10]), (2, 1, 1))
    pf = ParticleFilter.from_priors(rng, means0, covs0, 400)
    truth = means0.copy()
    rows = {k: [] for k in ("mean", "cov", "ess", "degenerate", "resampled")}
    for t in range(6):
        u = np.column_stack([rng.uniform(-3000, 3000, (2, 2)), np.zeros(2)])
        truth = dyn.step(truth, u, rng)
        pf.predict(rng, dyn.a, dyn.b, dyn.q_chol, u)
        observer = np.array([150.0 + 40 * t, 200.0, 40.0])
        scan = observe(rng, m.sensor, truth[:, :3], observer)
        sensor = m.sensor
        if t == 3:  # target 1 missed under p_D = 1: no particle explains an empty set
            scan = Scan(scan.bearings[:, :1] * np.array([[1.0], [0.0]]), np.array([[True], [False]]),
                        np.array([[True], [False]]))
            sensor = BearingModel(m.sensor.sigma, 1.0, 0.0)
        rows["degenerate"].append(pf.update(scan_loglik(scan, pf.particles, observer, sensor))[0])
        rows["ess"].append(pf.ess())
        rows["resampled"].append(pf.resample(rng, 0.5, roughening=0.2))
        mean, cov = pf.moments()
        rows["mean"].append(mean)
        rows["cov"].append(cov)
    return {**{k: np.array(v) for k, v in rows.items()}, "particles": pf.particles, "logw": pf.logw}


class RecordingGuidance:
    """Wraps the real guidance and keeps every plan's controls and means in call order."""

    def __init__(self, guidance):
        self.inner, self.controls, self.means = guidance, [], []

    def replan(self, mean, cov, goal, previous, step, shift=1, applied=None):
        return self.plan(mean, cov, goal, warm=previous, step=step, shift=shift, applied=applied)

    def sensitivity(self, *args, **kw):  # the truth's, for the PCRLB: its plans are not recorded
        return self.inner.sensitivity(*args, **kw)

    def plan(self, *args, **kw):
        plan = self.inner.plan(*args, **kw)
        assert plan.ok, plan.status
        self.controls.append(plan.controls)
        self.means.append(plan.means)
        return plan


def loop_reference(out: dict) -> None:
    m = load_mission(PAPER, {"steps": 4, "trials": 1, "filter.particles": 300})
    sim = Simulation(m, "optimized")
    sim.guidance = recorder = RecordingGuidance(sim.guidance)
    infos = [sim.reset(trial_seeds(m.seed, 1)[0])] + [sim.step() for _ in range(m.steps)]
    out |= {"loop/mean": np.array([i.mean for i in infos]), "loop/cov": np.array([i.cov for i in infos]),
            "loop/observer": np.array([i.observers[0] for i in infos]),
            "loop/scores": np.array([i.scores for i in infos[1:]]),
            "loop/resampled": np.array([any(e.startswith("resampled") for e in i.events) for i in infos[1:]]),
            "loop/particles": infos[-1].particles}
    # plans have different horizons ("shrinking"): store them padded, with their lengths
    lengths = np.array([len(c) for c in recorder.controls])
    pad = lengths.max()
    out |= {"loop/plan_lengths": lengths,
            "loop/plan_controls": np.array([np.pad(c, ((0, pad - len(c)), (0, 0))) for c in recorder.controls]),
            "loop/plan_means": np.array([np.pad(c, ((0, pad - len(c)), (0, 0))) for c in recorder.means])}


def main() -> None:
    out: dict[str, np.ndarray] = {}
    likelihood_reference(out)
    out |= {f"pf/{k}": v for k, v in filter_run().items()}
    loop_reference(out)
    path = HERE / "filter_reference.npz"
    np.savez_compressed(path, **out)
    print(f"{path}: {len(out)} arrays, {path.stat().st_size / 1e3:.0f} kB")


if __name__ == "__main__":
    main()
