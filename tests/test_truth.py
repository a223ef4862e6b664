"""The true targets never enter a building: starts with room to brake or turn, noise kept
clear of the walls, every step checked from the start."""

from types import SimpleNamespace

import numpy as np
import pytest

from uavsim.campaign import run_trial, trial_seeds
from uavsim.config import load_mission
from uavsim.sim import Simulation
from uavsim.truth import true_plan

WORLD = """name = "wall"
[area]
min_m = [0.0, 0.0, 0.0]
max_m = [600.0, 400.0, 200.0]
[[obstacles]]
name = "W"
min_m = [300.0, 0.0, 0.0]
max_m = [320.0, 330.0, 40.0]
[[goals]]
name = "east"
center_m = [500.0, 200.0]
size_m = [60.0, 60.0]
"""


def mission(tmp_path, position, velocity, variances, **overrides):
    """One target east-bound at ``position`` with ``velocity``, towards a goal behind a
    wall (x in [300, 320], y < 330: inflated by 9 m, its west face at x = 291)."""
    (tmp_path / "w.toml").write_text(WORLD)
    text = (f'world = "w.toml"\nsteps = 30\n[guidance]\nhorizon = 30\n[[targets]]\nname = "T1"\n'
            f"position_m = [{position[0]}, {position[1]}, 0.0]\nvelocity_mps = [{velocity[0]}, {velocity[1]}, 0.0]\n"
            f"cov0_si = {list(variances)}\ngoal = \"east\"\n")
    (tmp_path / "m.toml").write_text(text)
    return load_mission(tmp_path / "m.toml", {"filter.particles": 200, **overrides})


def test_a_start_that_cannot_stop_short_of_the_wall_is_not_taken(tmp_path):
    """Draws 18-48 m west of the wall's inflated face at 14-16 m/s eastwards: braking at
    6000 N on 1300 kg with friction 0.2 takes more than one step, so many such starts can
    only plan by dropping the wall's avoidance for their first steps (the sampler before
    this check took them: 9 truth steps through the wall in 3 of these 20 trials).  Every
    accepted start keeps every
    avoidance row (its plan guards from step 2), starts and first steps outside the
    margin, and no truth step touches the wall, over 20 trials."""
    m = mission(tmp_path, (258.0, 150.0), (15.0, 0.0), [100.0, 100.0, 1e-10, 1.0, 1.0, 1e-10])
    sim = Simulation(m, "optimized")
    margins = 0
    for seed in trial_seeds(5, 20):
        sim.reset(seed)
        x0 = sim.truth.state[0]
        p1 = x0[:2] + m.dynamics.dt * x0[3:5]
        ground = sim.guidance.geom.polys
        assert not ground.contains(x0[:2]).any() and not ground.contains(p1).any()
        assert sim.truth.plans[0].guarded_from == 2
        margins += sum("avoids every obstacle" in e for e in sim.truth.notes)
        for _ in range(m.steps):
            sim.step()
        assert sim.truth.collisions == 0
    assert margins >= 3  # the case happened: some first draws could not stop in time


def test_stochastic_noise_is_drawn_again_where_it_would_enter_a_building(tmp_path):
    """A stochastic truth driving along the wall with process noise of 6 m per step
    (Q = 36 m^2): with the noise unrestricted, 11 of 150 steps (5 trials of 30) crossed
    into the wall; here no step of this trial touches it, though at least 5 come within
    two noise sigmas of its inflated face, and the event log says nothing of collisions."""
    q = [36.0, 36.0, 1e-10, 3.0, 3.0, 1e-10]
    m = mission(tmp_path, (280.0, 20.0), (0.0, 8.0), [1.0, 1.0, 1e-10, 0.1, 0.1, 1e-10],
                truth="stochastic", **{"dynamics.process_noise_cov_si": q})
    result = run_trial(m, "baseline", 0, trial_seeds(8, 1)[0])
    assert result.collisions == 0
    assert not any("touches an obstacle" in e for e in result.events)
    near = np.abs(result.truth[:, 0, 0] - 291.0) < 12.0  # steps within two noise sigmas of the inflated face
    assert near.sum() >= 5


def test_a_plan_that_drops_avoidance_is_an_event(tmp_path):
    """A filter estimate 4 m inside the wall's margin heading into it: the plan can only
    avoid the wall from a later step, and says so; the closed loop logs it."""
    m = mission(tmp_path, (200.0, 150.0), (0.0, 0.0), [1.0, 1.0, 1e-10, 0.1, 0.1, 1e-10])
    sim = Simulation(m, "optimized")
    plan = sim.guidance.plan(np.array([287.0, 150.0, 0.0, 15.0, 0.0, 0.0]), np.zeros((6, 6)), m.goals[0])
    assert plan.ok and plan.guarded_from > 2 and plan.eventful
    assert "start inside the margin of 'W'" in plan.message


@pytest.mark.parametrize("truth", ["planned", "stochastic"])
def test_the_summary_counts_truth_collisions_from_the_first_step(tmp_path, truth):
    """The count is zero on this world, and the summary carries it beside the events."""
    from uavsim.campaign import run_campaign

    m = mission(tmp_path, (150.0, 150.0), (5.0, 0.0), [100.0, 100.0, 1e-10, 4.0, 4.0, 1e-10], truth=truth,
                steps=10, trials=2)
    s = run_campaign(m, "baseline")
    assert s["truth_collisions"] == 0 and "events" in s


def test_start_prior_is_the_share_kept_and_its_covariance(tmp_path):
    """A prior centred on the wall's inflated west face (x = 291), at rest with velocity
    variance 1e-10 (the first step is the start): a start is kept when x < 291 (or beyond
    the inflated east face at 329, 3.8 sd away), so the share is 0.5 + 7e-5; from 4000
    draws its binomial standard error is 0.0079, and the tolerance is 4 of them.

    The kept starts' x is a half normal: variance ``100 (1 - 2 / pi) = 36.34``.  The
    estimate ``100 + S_kept - S_all`` errs by at most the sum of the two sample variances'
    standard errors: ``sqrt((mu_4 - sigma^4) / 2000) = 1.37`` for the half normal (``mu_4 =
    0.510``, ``sigma^2 = 0.363`` in units of 100) and ``100 sqrt(2 / 4000) = 2.24``; the
    tolerance is 4 x 3.61.  y is not restricted: ``100 + (S_kept - S_rejected) / 2``, s.e.
    ``sqrt(2 x 100^2 x 2 / 2000) / 2 = 2.24``, tolerance 4 of them.  A prior far from the
    wall keeps every draw: share 1 and ``Sigma_0`` itself, exactly."""
    from uavsim.truth import start_prior

    on_face = mission(tmp_path, (291.0, 150.0), (0.0, 0.0), [100.0, 100.0, 1e-10, 1e-10, 1e-10, 1e-10])
    share, cov = start_prior(on_face, np.random.default_rng(0))
    assert share[0] == pytest.approx(0.5, abs=4 * 0.0079)
    assert cov[0, 0, 0] == pytest.approx(100 * (1 - 2 / np.pi), abs=4 * 3.61)
    assert cov[0, 1, 1] == pytest.approx(100.0, abs=4 * 2.24)
    assert cov[0, 2, 2] == on_face.targets[0].cov0[2, 2]  # z is not the bound's: Sigma_0's
    assert np.linalg.eigvalsh(cov[0]).min() > 0
    clear = mission(tmp_path, (100.0, 150.0), (0.0, 0.0), [100.0, 100.0, 1e-10, 1.0, 1.0, 1e-10])
    share, cov = start_prior(clear, np.random.default_rng(0))
    assert share[0] == 1.0 and np.array_equal(cov[0], clear.targets[0].cov0)


def test_the_campaign_bound_takes_the_prior_the_starts_come_from(tmp_path):
    """The wall-face prior of the test above, moving (velocity variance 1): about half of
    it is cut.  With no sensor the bound is the prior carried by the plans' sensitivity,
    ``E[G] C E[G]^T``: the campaign's equals it with C the restricted covariance of
    :func:`uavsim.truth.start_prior` (x variance near 36 m^2), and is below the one with
    ``Sigma_0`` (x variance 100 m^2) by more than 10%: about 11.6 m against 14 m."""
    from uavsim.bounds.pcrlb import pcrlb_planned
    from uavsim.campaign import load_trials, run_campaign, trial_key
    from uavsim.truth import start_prior

    m = mission(tmp_path, (291.0, 150.0), (0.0, 0.0), [100.0, 100.0, 1e-10, 1.0, 1.0, 1e-10], steps=3, trials=3)
    s = run_campaign(m, "baseline", out=tmp_path / "c")
    trials = load_trials(tmp_path / "c" / "trials", range(3), trial_key(m, "baseline"))
    sens, truth, obs = (np.stack([getattr(trials[k], f) for k in range(3)]) for f in ("sensitivity", "truth",
                                                                                       "observers"))
    restricted = pcrlb_planned(sens, truth, obs, start_prior(m, np.random.default_rng(m.seed))[1], m.sensor).pos
    whole = pcrlb_planned(sens, truth, obs, np.array([m.targets[0].cov0]), m.sensor).pos
    assert s["pcrlb_start_acceptance"][0] == pytest.approx(0.5, abs=4 * 0.0079)
    assert s["pcrlb_pos"] == pytest.approx(restricted.tolist(), rel=1e-12)
    assert np.all(restricted < 0.9 * whole)


def _plan(objective, status="feasible", ok=True, guarded_from=2):
    return SimpleNamespace(objective=objective, status=status, ok=ok, guarded_from=guarded_from)


@pytest.mark.parametrize("warm, cold, flies, solves", [
    (_plan(10.0, "optimal"), _plan(5.0, "optimal"), "warm", 1),  # certified: no second search
    (_plan(10.0), _plan(5.0, "optimal"), "cold", 2),  # the budget stopped it on a worse route
    (_plan(5.0), _plan(10.0), "warm", 2),  # the cold search did worse within its limit
    (_plan(10.0), _plan(5.0, "infeasible", ok=False), "warm", 2),
    (_plan(10.0, "infeasible", ok=False), _plan(50.0), "cold", 2),
    (_plan(10.0), _plan(5.0, guarded_from=3), "warm", 2),  # leaves an avoidance constraint at step 2
])
def test_a_true_target_flies_the_better_of_its_warm_and_cold_searches(warm, cold, flies, solves):
    """``true_plan``: the search warm from the prior's plan, and where that is not certified
    the cold search within the first plan's time limit; the usable plan with the lower
    objective flies (stub guidance: which plan each search returns is given)."""
    calls = []

    class Guidance:
        def plan(self, x, cov, goal, warm=None, step=0, shift=1):
            calls.append(warm)
            return plans[warm is None]

    plans = {False: warm, True: cold}
    prior = object()
    got = true_plan(Guidance(), np.zeros(6), np.zeros(3), prior)
    assert got is {"warm": warm, "cold": cold}[flies]
    assert calls == [prior, None][:solves]
