"""The particle filter computes the numbers it computed at commit 8c473d3, before its speed-ups.

``tests/data/filter_reference.npz`` holds the outputs of the implementation of commit
8c473d3 on fixed seeds (``tests/data/make_filter_reference.py`` wrote it once).  The new
code reorders floating-point operations (the association hypotheses on a leading axis,
the wrap of the residual without ``mod``, batched matrix products for the moments), so
the comparisons allow rounding and nothing more; the tolerances are derived below."""


import numpy as np
import pytest

from uavsim.campaign import trial_seeds
from uavsim.config import load_mission
from uavsim.guidance import Plan
from uavsim.sensing import BearingModel, log_likelihood
from uavsim.sim import Simulation

from .conftest import PAPER, ROOT
from .data.make_filter_reference import filter_run

REF = np.load(ROOT / "tests" / "data" / "filter_reference.npz")
EPS = np.finfo(float).eps
CASES = sorted({k.split("/")[1] for k in REF.files if k.startswith("lik/")})


@pytest.mark.parametrize("case", CASES)
def test_likelihood_matches_the_stored_outputs(case):
    """Both versions compute the wrapped residual r = phi - l(x, s) from angles of size
    <= 2 pi with a few roundings: |dr| <= delta = 4 ulp(2 pi) = 8 pi eps.  The exponent
    r^2 / (2 sigma^2) then moves by at most |r| delta / sigma^2 <= pi delta / sigma^2
    (6e-11 for sigma = 1 deg); the log-sum-exp adds a few eps of the result.  Zeros of
    the likelihood (-inf) must stay exactly -inf."""
    p = f"lik/{case}/"
    sigma, pd, lam = REF[p + "sensor"]
    got = log_likelihood(REF[p + "bearings"], REF[p + "valid"], REF[p + "expected"], BearingModel(sigma, pd, lam))
    want = REF[p + "loglik"]
    finite = np.isfinite(want)
    np.testing.assert_array_equal(got[~finite], want[~finite])
    bound = np.pi * 8 * np.pi * EPS / sigma**2 + 8 * EPS * np.abs(want[finite])
    np.testing.assert_array_less(np.abs(got[finite] - want[finite]), bound)


def test_filter_steps_match_the_stored_run():
    """Predict, update, resampling with roughening and moments, six steps with one
    degenerate update (make_filter_reference.filter_run, rerun here).  Every step's
    likelihood differs from the old one by rounding (above); the weights, the resampling
    decisions and indices then agree, so means and covariances differ by rounding in
    sums of 400 terms: relative 1e-9 is generous, and a different resampling decision or
    index would move them by ~1e-3."""
    got = filter_run()
    for key in ("degenerate", "resampled"):
        np.testing.assert_array_equal(got[key], REF[f"pf/{key}"])
    for key in ("ess", "mean", "particles", "logw"):
        np.testing.assert_allclose(got[key], REF[f"pf/{key}"], rtol=1e-9)
    cov = REF["pf/cov"]
    np.testing.assert_allclose(got["cov"], cov, rtol=1e-9, atol=1e-9 * np.abs(cov).max())


class ReplayedGuidance:
    """The guidance plans the stored trial used, in call order (the guidance solver may
    change plans at its own tolerance; this test is about the filter and the decision)."""

    def __init__(self, guidance):
        self.inner, self.calls = guidance, 0

    def __getattr__(self, name):  # the geometry and the rest: the real guidance's
        return getattr(self.inner, name)

    def replan(self, mean, cov, goal, previous, step, shift=1, applied=None):
        return self._next()

    def sensitivity(self, start, goal, plan, step=0):  # the truth's, for the PCRLB only
        return np.zeros((len(plan.means), 4, 4)), True

    def plan(self, *args, **kw):
        if "warm" not in kw:  # the truth's plan at the prior's mean, only its warm start: none here
            return Plan(status="error", objective=np.inf, lower_bound=np.nan, gap=np.inf, iterations=0,
                        solve_seconds=0.0, controls=None, means=None, covs=None)
        return self._next()

    def _next(self) -> Plan:
        k, self.calls = self.calls, self.calls + 1
        t = REF["loop/plan_lengths"][k]
        return Plan(status="optimal", objective=0.0, lower_bound=0.0, gap=0.0, iterations=1, solve_seconds=0.0,
                    controls=REF["loop/plan_controls"][k, :t], means=REF["loop/plan_means"][k, :t], covs=None)


def test_closed_loop_trial_matches_the_stored_trial():
    """One trial of the paper mission (300 particles, 4 steps) with the stored plans: the
    UAV takes the same moves (the decision scores agree to the float32 planner's
    1e-5, and no two candidates are that close), the filter resamples at the same steps,
    and the per-step means and covariances agree to rounding (relative 1e-9, as above)."""
    m = load_mission(PAPER, {"steps": 4, "trials": 1, "filter.particles": 300})
    sim = Simulation(m, "optimized")
    sim.guidance = ReplayedGuidance(sim.guidance)
    infos = [sim.reset(trial_seeds(m.seed, 1)[0])] + [sim.step() for _ in range(m.steps)]
    assert sim.guidance.calls == len(REF["loop/plan_lengths"])
    np.testing.assert_array_equal(np.array([i.observers[0] for i in infos]), REF["loop/observer"])
    np.testing.assert_allclose(np.array([i.scores for i in infos[1:]]), REF["loop/scores"], rtol=1e-5)
    resampled = [any(e.startswith("resampled") for e in i.events) for i in infos[1:]]
    np.testing.assert_array_equal(resampled, REF["loop/resampled"])
    np.testing.assert_allclose(np.array([i.mean for i in infos]), REF["loop/mean"], rtol=1e-9)
    cov = REF["loop/cov"]
    np.testing.assert_allclose(np.array([i.cov for i in infos]), cov, rtol=1e-9, atol=1e-9 * np.abs(cov).max())
    np.testing.assert_allclose(infos[-1].particles, REF["loop/particles"], rtol=1e-9)
