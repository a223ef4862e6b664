"""Closed loop ([Papaioannou2023, Sec. V-VI]): determinism, seeding, manoeuvres, the commands."""

import dataclasses
import json

import numpy as np
import pytest

from uavsim.campaign import kept_guidance, run_campaign, run_trial, trial_seeds
from uavsim.cli import main
from uavsim.config import load_mission
from uavsim.sim import Simulation, model_positions
from uavsim.uav import Route, manoeuvre_loop, manoeuvre_route

from .conftest import PAPER, ROOT

CONSTRAINED = ROOT / "missions" / "paper_constrained.toml"


def small(path=PAPER, steps=4, trials=2, particles=400, **overrides):
    return load_mission(path, {"steps": steps, "trials": trials, "filter.particles": particles, **overrides})


def strip(summary):
    return {k: v for k, v in summary.items() if k not in ("timing", "wall_seconds")}


def test_same_seed_same_summary():
    m = small()
    assert strip(run_campaign(m, "optimized")) == strip(run_campaign(m, "optimized"))
    other = strip(run_campaign(small(seed=m.seed + 1), "optimized"))
    assert other["rmse"] != strip(run_campaign(m, "optimized"))["rmse"]


def test_trial_k_does_not_depend_on_the_campaign_size():
    m = small()
    a = run_trial(m, "optimized", 1, trial_seeds(m.seed, 2)[1])
    b = run_trial(m, "optimized", 1, trial_seeds(m.seed, 5)[1])
    np.testing.assert_array_equal(a.err2, b.err2)


def test_planners_share_truth_and_prior_particles():
    """Common random numbers: trial k has the same truth whichever planner flies."""
    m = small(truth="stochastic")
    seen = {}
    for planner in ("optimized", "circle"):
        truths = []
        run_trial(m, planner, 0, trial_seeds(m.seed, 1)[0], on_step=lambda info, out=truths: out.append(info.truth))
        seen[planner] = np.array(truths)
    np.testing.assert_array_equal(seen["optimized"][0], seen["circle"][0])  # the drawn true start
    assert seen["optimized"].shape == (m.steps + 1, 4, 6)


def test_manoeuvre_loops_by_hand():
    cfg = load_mission(CONSTRAINED).planner.manoeuvres
    sq = manoeuvre_loop("square", cfg)
    np.testing.assert_allclose(np.linalg.norm(np.diff(np.vstack([sq, sq[:1]]), axis=0), axis=1), cfg.square_side)
    pent = manoeuvre_loop("pentagon", cfg)
    side = 2 * cfg.pentagon_radius * np.sin(np.pi / 5)
    np.testing.assert_allclose(np.linalg.norm(np.diff(np.vstack([pent, pent[:1]]), axis=0), axis=1), side)
    circ = manoeuvre_loop("circle", cfg)
    np.testing.assert_allclose(np.linalg.norm(circ - circ.mean(0), axis=1), cfg.circle_radius)
    zz = manoeuvre_loop("zigzag", cfg)
    assert zz[:, 0].max() == cfg.zigzag_length and zz[:, 1].max() == cfg.zigzag_width
    np.testing.assert_array_equal(sq[0], [0, 0])


@pytest.mark.parametrize("name", ["zigzag", "square", "pentagon", "circle"])
def test_manoeuvres_stay_in_the_region_clear_of_obstacles(name):
    m = load_mission(CONSTRAINED)
    rng = np.random.default_rng(0)
    for start in rng.uniform([0, 0], [1000, 220], (5, 2)):
        route = manoeuvre_route(name, np.r_[start, 40.0], m.planner.manoeuvres, m.uav, m.world)
        pts = np.array([route.position(k) for k in range(120)])
        assert m.uav.region.contains(pts).all() and not m.world.in_obstacle(pts).any()
        assert not m.world.segment_blocked(pts[:-1], pts[1:]).any()
        steps = np.linalg.norm(np.diff(pts[:, :2], axis=0), axis=1)
        assert np.all(steps <= m.planner.manoeuvres.step + 1e-9)


def test_route_speed_is_the_step_length():
    route = Route(np.array([0.0, 0.0, 40.0]), np.array([[0.0, 0.0], [100.0, 0.0], [100.0, 100.0], [0.0, 100.0]]),
                  20.0, 40.0)
    np.testing.assert_allclose(route.position(3), [60, 0, 40])
    np.testing.assert_allclose(route.position(7), [100, 40, 40])
    np.testing.assert_allclose(route.position(20), [0, 0, 40])  # perimeter 400 m = 20 steps


def test_fixed_sensors_observe_from_three_places():
    m = small(steps=2)
    infos = []
    run_trial(m, "fixed-sensors", 0, trial_seeds(m.seed, 1)[0], on_step=infos.append)
    assert infos[1].observers.shape == (3, 3) and len(infos[1].scans) == 3
    assert not any(s.valid[~s.from_target].any() for s in infos[1].scans)  # no clutter
    np.testing.assert_array_equal(infos[1].observers[:, :2], [[150, 200], [800, 200], [500, 900]])


def test_optimized_moves_are_grid_moves():
    m = small(steps=3)
    infos = []
    run_trial(m, "optimized", 0, trial_seeds(m.seed, 1)[0], on_step=infos.append)
    for a, b in zip(infos[:-1], infos[1:]):
        d = b.observers[0, :2] - a.observers[0, :2]
        r = np.linalg.norm(d)
        assert np.isclose(r % m.uav.step, 0, atol=1e-9) or np.isclose(r % m.uav.step, m.uav.step, atol=1e-9)
        assert np.isfinite(b.scores[np.argmin(b.scores)])


def write_small_mission(tmp_path):
    text = PAPER.read_text().replace("particles = 5000", "particles = 300")
    text = text.replace('world = "../worlds/paper.toml"', f'world = "{ROOT / "worlds" / "paper.toml"}"')
    path = tmp_path / "small.toml"
    path.write_text(text)
    return path


def test_run_writes_summary(tmp_path, capsys):
    mission = write_small_mission(tmp_path)
    out = tmp_path / "out"
    argv = ["run", str(mission), "--trials", "2", "--steps", "3", "--seed", "5", "--out", str(out), "--quiet"]
    assert main(argv) == 0
    s = json.loads((out / "summary.json").read_text())
    for key in ("mission", "planner", "trials", "steps", "seed", "rmse", "rmse_per_target", "time_avg_rmse", "timing"):
        assert key in s
    assert (s["trials"], s["steps"], s["seed"], s["planner"]) == (2, 3, 5, "optimized")
    assert len(s["rmse"]) == 3 and np.array(s["rmse_per_target"]).shape == (4, 3)
    assert set(s["timing"]) >= {"guidance", "filter", "planner", "total"}
    assert "time-avg RMSE" in capsys.readouterr().out


def test_compare_writes_json_and_png(tmp_path):
    mission = write_small_mission(tmp_path)
    out = tmp_path / "cmp"
    assert main(["compare", str(mission), "--planners", "optimized,fixed-sensors", "--trials", "1", "--steps", "2",
                 "--out", str(out), "--quiet"]) == 0
    data = json.loads((out / "compare.json").read_text())
    assert list(data) == ["optimized", "fixed-sensors"]
    assert (out / "rmse.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("argv, fragment", [
    (["compare", "M", "--planners", "optimized,spiral", "--out", "x"], "unknown spiral"),
    (["run", "M", "--trials", "0"], "trials: must be in [1, 1000000], got 0 (an override, not the file's value)"),
    (["run", "M", "--clutter-rate", "-1"], "sensor.clutter_rate: must be in [0, 100] per scan, got -1"),
])
def test_bad_command_lines_exit_2(tmp_path, capsys, argv, fragment):
    argv = [str(write_small_mission(tmp_path)) if a == "M" else a for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and fragment in err and len(err.splitlines()) == 1


def test_failed_first_replan_flies_the_prior_plan_and_is_logged():
    """A belief with no plan (here lifted 5 m off the ground, which P1 refuses) at the
    first step flies the plan from the prior mean (the first re-plans' warm start), and
    the step logs why."""
    m = small(steps=1)
    sim = Simulation(m, "optimized")
    sim.reset(1)
    prior = sim.guidance.plan(m.targets[0].mean0, m.targets[0].cov0, m.goals[0])
    sim.belief.pf.particles[0, :, 2] = 5.0
    info = sim.step()
    assert info.plans[0].status == "fallback" and np.array_equal(info.plans[0].controls, prior.controls)
    assert any("T1 (estimate): re-plan error" in e and "flying the previous plan" in e for e in info.events)
    assert np.all(np.isfinite(info.mean))


def test_failed_replan_without_a_plan_to_fly_coasts_and_is_logged():
    """No plan from the belief and none from the prior to fall back on: the filter
    predicts with zero force and the step logs why, instead of raising."""
    m = small(steps=1)
    sim = Simulation(m, "optimized")
    sim.reset(1)
    sim._prior_plan = lambda j: None  # as where the prior mean has no plan
    sim.belief.pf.particles[0, :, 2] = 5.0
    info = sim.step()
    assert info.plans[0].status == "fallback" and np.all(info.plans[0].controls == 0)
    assert any("T1 (estimate): no plan" in e and "coasting" in e for e in info.events)
    assert np.all(np.isfinite(info.mean))


def test_a_belief_heading_out_of_the_area_is_planned_from_rest_and_logged():
    """A belief 2 m inside the area's north edge heading north at 16 m/s has no plan
    (tests/test_guidance.py, the same start): the step plans from rest there, uses that
    plan's force and logs why."""
    m = small(steps=1)
    sim = Simulation(m, "optimized")
    sim.reset(1)
    sim.belief.pf.particles[2, :, :2] = [500.0, m.world.area_hi[1] - 2.0]
    sim.belief.pf.particles[2, :, 3:5] = [0.0, 16.0]
    info = sim.step()
    assert info.plans[2].ok and info.plans[2].moved_start and info.plans[2].status in ("optimal", "feasible")
    assert any(e.startswith("T3 (estimate): no plan from the estimated velocity") and "planned from rest" in e
               for e in info.events)


def test_a_belief_inside_an_obstacle_plans_its_way_out():
    """An estimate can lie inside an obstacle (a true target cannot): the re-plan drops the
    avoidance only where it cannot hold and flies out, no fallback, no event."""
    m = small(steps=1)
    sim = Simulation(m, "optimized")
    sim.reset(1)
    sim.belief.pf.particles[0, :, :2] = [375.0, 520.0]  # target 0's whole belief inside obstacle A
    info = sim.step()
    assert info.plans[0].ok and info.plans[0].status in ("optimal", "feasible")
    assert "start inside the margin of 'A'" in info.plans[0].message
    assert not any("plan" in e for e in info.events)


def test_a_prior_that_only_crashes_is_a_mission_error(tmp_path, capsys):
    """A target 0.5 m west of obstacle A heading into it at 10 m/s passes validation (it
    is outside the obstacle), but with a tight prior every true start drawn from it hits
    the obstacle within its first step, which no force can change: exit 2 naming the
    target's prior."""
    text = write_small_mission(tmp_path).read_text()
    text = text.replace("position_m = [281.0, 925.0, 0.0]",
                        "position_m = [299.5, 520.0, 0.0]\nvelocity_mps = [10.0, 0.0, 0.0]")
    wide, tight = "[200.0, 200.0, 1e-10, 20.0, 20.0, 1e-10]", "[1e-7, 1e-7, 1e-10, 1e-7, 1e-7, 1e-10]"
    text = text.replace(f"cov0_si = {wide}", f"cov0_si = {tight}", 1)
    path = tmp_path / "wall.toml"
    path.write_text(text)
    for workers in ("1", "2"):  # raised here, or in a worker process and re-raised here
        assert main(["run", str(path), "--trials", "2", "--steps", "1", "--workers", workers, "--quiet",
                     "--out", str(tmp_path / workers)]) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"error: {path}: targets[0].cov0_si: none of 1000 draws from the prior"), err


CLUTTER_FREE = ROOT / "missions" / "paper_clutterfree.toml"


@pytest.mark.parametrize("kind", ["plkf", "bc-plkf", "iv-plkf", "ub-plkf", "vc-plkf"])
def test_pseudo_linear_filters_in_the_closed_loop(kind):
    """[Huang2021]'s filters in place of particles (clutter-free): finite beliefs, symmetric
    positive semi-definite covariances, no particles in the step record."""
    m = load_mission(CLUTTER_FREE, {"filter.kind": kind, "steps": 3})
    sim = Simulation(m, "optimized")
    assert sim.reset(0).particles is None
    for _ in range(3):
        info = sim.step()
    assert np.isfinite(info.mean).all() and np.isfinite(info.cov).all()
    np.testing.assert_allclose(info.cov, info.cov.transpose(0, 2, 1), atol=1e-9)
    assert np.linalg.eigvalsh(info.cov).min() > -1e-6 * np.abs(info.cov).max()
    assert np.isfinite(info.scores).any()


@pytest.mark.parametrize("planner", ["optimized", "seek"])
def test_a_pseudo_linear_filter_runs_with_the_uav_right_above_a_prior_mean(planner):
    """The UAV starts right above target 0's prior mean: staying there is one of Eq. (13)'s
    candidates, where the linearised bearing's gradient is undefined.  With the range floored
    (:data:`uavsim.belief.traces.MIN_RANGE_M`) that candidate scores target 0 at its
    prediction's trace (no measurement), and the run goes on with finite beliefs."""
    start = load_mission(CLUTTER_FREE).targets[0].mean0
    m = load_mission(CLUTTER_FREE, {"filter.kind": "plkf", "steps": 3, "uav.random_start": False,
                                    "uav.start_m": [float(start[0]), float(start[1]), 40.0]})
    sim = Simulation(m, planner)
    sim.reset(0)
    mean, cov = sim.belief.moments()
    np.testing.assert_array_equal(mean[0, :2], start[:2])
    here = sim.belief.traces(sim.policy.position[None], sim.policy.sensor)
    assert here[0, 0] == pytest.approx(np.trace(cov[0]), rel=1e-12)
    for _ in range(3):
        info = sim.step()
    assert np.isfinite(info.mean).all() and np.isfinite(info.scores).any()


def test_iv_plkf_tracks_the_clutter_free_paper_mission():
    """Measured with 2 trials x 30 steps (mission file): IV-PLKF 11.0 m against the
    particle filter's 9.2 m.  Bound: within twice the particle filter's RMSE."""
    m = load_mission(CLUTTER_FREE, {"steps": 30, "trials": 2})
    iv = run_campaign(m, "optimized")
    pf = run_campaign(load_mission(CLUTTER_FREE, {"steps": 30, "trials": 2, "filter.kind": "particle",
                                                    "filter.particles": 5000}), "optimized")
    assert iv["time_avg_rmse"] < 2 * pf["time_avg_rmse"]


def test_plan_clusters_2_moves_each_half_by_the_plan_from_its_own_mean():
    """``[filter] plan_clusters = 2``: target 0's cloud made of two parts heading opposite
    ways (vx = +8 and -8 m/s) is split into exactly those parts, each part's plan is the
    re-plan from its own weighted moments, and the prediction moves each part by its own
    plan's first force (checked against Eq. 9a with the filter generator's normals)."""
    from uavsim.belief.particle import halves, weighted_moments

    m = small(steps=1, **{"filter.plan_clusters": 2})
    sim = Simulation(m, "optimized")
    sim.reset(1)
    pf = sim.belief.pf
    pf.particles[0, :, 3] = np.where(np.arange(pf.particles.shape[1]) % 2 == 0, 8.0, -8.0)
    x0, w = pf.particles.copy(), pf.weights.copy()
    rng_state = sim.belief.rng.bit_generator.state
    sim.prepare()
    mask = halves(x0, w)
    assert np.array_equal(mask[0], x0[0, :, 3] > 0) or np.array_equal(mask[0], x0[0, :, 3] < 0)
    plans = sim.half_plans[0]
    forces = []
    for h, part in enumerate((~mask[0], mask[0])):
        mu, cov = weighted_moments(x0[:1], (w[0] * part / (w[0] * part).sum())[None])
        again = sim.guidance.replan(mu[0], cov[0], m.goals[0], None, 0)
        np.testing.assert_allclose(plans[h].controls[0], again.controls[0], rtol=1e-6, atol=1e-3)
        forces.append(plans[h].controls[0])
    assert np.linalg.norm(forces[0] - forces[1]) > 100.0  # the two parts are steered differently
    rng = np.random.default_rng()
    rng.bit_generator.state = rng_state
    z = rng.standard_normal(x0.shape)
    d = m.dynamics
    want = x0[0] @ d.a.T + z[0] @ d.q_chol.T + np.where(mask[0][:, None], forces[1] @ d.b.T, forces[0] @ d.b.T)
    np.testing.assert_allclose(pf.particles[0], want, rtol=1e-9, atol=1e-6)
    # no plan is made from the split cloud's mean: the target's plan is its heavier half's
    heavier = int((w[0] * mask[0]).sum() > (w[0] * ~mask[0]).sum())  # as the closed loop weighs them
    assert sim.plans[0] is plans[heavier]
    sim.step()
    assert len(sim.replans) == sum(len(h) or 1 for h in sim.half_plans)
    assert all(sim.plans[j] in (h or [sim.plans[j]]) for j, h in enumerate(sim.half_plans))


def test_with_the_link_term_a_filter_on_the_truth_applies_the_truths_forces():
    """The link term end to end (truth, particles' applied forces, the re-plan's link):
    a filter whose prior is the truth's start to a millimetre, without process noise,
    re-plans every step the forces of the plan the truth made once, to within 0.1 N over
    six steps of the paper mission; P1 as published re-plans other forces from step 1 on
    (176-605 N apart when written)."""
    tight = np.diag([1e-6, 1e-6, 1e-10, 1e-8, 1e-8, 1e-10])
    gaps = {}
    for link in (False, True):
        m = load_mission(PAPER, {"steps": 6, "trials": 1, "filter.particles": 100, "filter.plan_clusters": 1,
                                 "filter.noise_scales": [1.0], "dynamics.process_noise_cov_si": [0.0] * 6,
                                 "guidance.link_applied_force": link, "guidance.horizon": 20})
        m = dataclasses.replace(m, targets=tuple(dataclasses.replace(t, cov0=tight) for t in m.targets))
        sim = Simulation(m, "optimized")
        sim.reset(0)
        gap = []
        for t in range(m.steps):
            sim.prepare()
            truth = np.array([p.controls[t, :2] for p in sim.truth.plans])
            gap.append(np.abs(np.array([p.controls[0, :2] for p in sim.plans]) - truth).max())
            sim.step()
        gaps[link] = np.array(gap)
    assert gaps[True].max() < 0.1
    assert gaps[False][1:].min() > 100.0


def test_keep_out_restricts_the_prior_and_weighs_particles_in_obstacles_zero(tmp_path):
    """``[filter] keep_out``: target 0's prior centred 10 m west of obstacle A (sd 14 m)
    reaches into A and its margins.  Every prior particle then passes the true starts' test
    (:func:`uavsim.truth.clear_starts`), and after each step no particle with weight lies in
    an obstacle; with it off (the paper's filter) a share of target 0's prior fails the
    test (half of it here) and particles with weight do lie inside (70-80 of 300 a step)."""
    text = write_small_mission(tmp_path).read_text().replace("position_m = [281.0, 925.0, 0.0]",
                                                             "position_m = [290.0, 520.0, 0.0]")
    (tmp_path / "near.toml").write_text(text)
    inside_weighed = {}
    for keep in (True, False):
        m = load_mission(tmp_path / "near.toml", {"steps": 3, "filter.keep_out": keep})
        sim = Simulation(m, "optimized")
        sim.reset(3)
        clear = sim._clear(sim.belief.pf.particles)
        if keep:
            assert clear.all()
        else:
            assert 0.3 < 1 - clear[0].mean() < 0.7 and clear[1:].all()
        seen = 0
        for _ in range(3):
            sim.step()
            seen += int((sim._inside(sim.belief.pf.particles[..., :3]) & (sim.belief.pf.weights > 0)).sum())
        inside_weighed[keep] = seen
    assert inside_weighed[True] == 0 and inside_weighed[False] > 0


def test_committed_plans_fly_the_truths_plan_and_renew_with_it():
    """``[filter] motion = "commit"`` end to end: a filter whose prior is the truth's start to
    a millimetre, without process noise, moves every particle by the forces of the plan the
    truth made once (to 1 N over eight steps, through the renewal at the end of a 5-step
    horizon, where truth and filter each plan again from where they are); it re-plans at
    those two steps only.  Re-planning every step (the paper's filter) flies other forces
    from step 1 on (see the link-term test above)."""
    tight = np.diag([1e-6, 1e-6, 1e-10, 1e-8, 1e-8, 1e-10])
    m = load_mission(PAPER, {"steps": 8, "trials": 1, "filter.particles": 100, "filter.motion": "commit",
                             "filter.plan_clusters": 2, "filter.noise_scales": [1.0],
                             "dynamics.process_noise_cov_si": [0.0] * 6, "guidance.horizon": 5})
    m = dataclasses.replace(m, targets=tuple(dataclasses.replace(t, cov0=tight) for t in m.targets))
    sim = Simulation(m, "optimized")
    sim.reset(0)
    gap, replanned = [], []
    for _ in range(m.steps):
        sim.step()
        truth = np.array([p.controls[(sim.t - 1) % 5, :2] for p in sim.truth.plans])
        gap.append(np.abs(sim.belief.pf.applied - truth[:, None, :]).max())
        replanned.append(len(sim.replans))
    assert max(gap) < 1.0
    assert replanned == [2 * len(m.targets), 0, 0, 0, 0, 2 * len(m.targets), 0, 0]


def test_first_committed_plans_are_made_once_and_change_no_trial():
    """``motion = "commit"``: the first step's clusters come from a reference cloud, so their
    plans are the same in every trial and a kept guidance makes them once: a second trial
    on the same guidance flies the very plans of the first (the same objects) and makes no
    plan of its own at step 0, and it gives, bit for bit, what it gives on a fresh guidance
    (a campaign's trials do not depend on which worker ran which)."""
    m = load_mission(PAPER, {"steps": 3, "trials": 2, "filter.particles": 200, "filter.motion": "commit",
                             "filter.plan_clusters": 3})
    seeds = trial_seeds(m.seed, 2)
    kept = Simulation(m, "optimized")
    kept.reset(seeds[0])
    kept.step()
    first = kept.committed
    again = Simulation(m, "optimized", kept.guidance)
    again.reset(seeds[1])
    cold = len(kept.guidance._cold)
    again.step()
    assert again.committed is first and len(kept.guidance._cold) == cold
    shared = run_trial(m, "optimized", 1, seeds[1], kept.guidance)
    fresh = run_trial(m, "optimized", 1, seeds[1])
    np.testing.assert_array_equal(shared.err2, fresh.err2)
    np.testing.assert_array_equal(shared.nees_pos, fresh.nees_pos)
    assert shared.events == fresh.events


def test_route_probes_add_a_cluster_for_a_route_none_takes():
    """The paper's world with the filter's defaults (16 committed clusters): T1's plan goes
    east of an obstacle from every cluster's mean, but from 5-7% of its prior's starts it
    goes west (3 of the first 10 trials' truths).  No cluster's model (plan plus gains times
    the start's offset) comes within 150 m of those truths over 30 steps; with the route
    probes one cluster is added for T1, and its model follows each of them to within 15 m
    (measured 3.9, 11.0 and 1.2 m), while the truths the clusters fitted stay fitted."""
    defaults = {"steps": 30, "trials": 10, "filter.motion": "commit", "filter.plan_clusters": 16,
                "filter.noise_scales": [0.003, 0.03, 0.3], "filter.loss_nats": 10.0, "filter.keep_out": True}
    seeds, miss, added = trial_seeds(2023, 10), {}, {}
    for probes in (0, 32):
        m = load_mission(PAPER, defaults | {"filter.route_probes": probes})
        sim = Simulation(m, "baseline", kept_guidance(m))
        sim.reset(seeds[0])
        (means, _, _, live), plans, gains, *_ = sim.first_commit(16)
        added[probes] = live.sum(axis=1) - 16
        miss[probes] = []
        for seed in seeds:
            sim.reset(seed)
            x0, truth = sim.truth.state[0], sim.truth.plans[0].means[:30, :2]
            ctl = np.array([p.controls for p in plans[0]])[live[0], :30]
            flown = model_positions(x0, means[0][live[0]], ctl, gains[0][live[0], :30], m.dynamics)
            miss[probes].append(np.linalg.norm(flown - truth, axis=2).max(axis=1).min())
    west = np.array(miss[0]) > 150.0
    assert np.flatnonzero(west).tolist() == [0, 3, 5]
    assert added[0].tolist() == [0, 0, 0, 0] and added[32][0] == 1
    assert (np.array(miss[32])[west] < 15.0).all()
    assert (np.array(miss[32])[~west] <= np.array(miss[0])[~west] + 1e-9).all()


def test_route_probes_are_planned_as_the_truth_would_be(monkeypatch):
    """A budget-limited search keeps its warm start's route, and the truth's first search
    from its start is warm from the plan at its prior mean (``truth.true_plan``, which adds a
    cold search only where that one is not certified).  A probe stands for such a truth, so
    it is planned as that search: every probe's solve is warm-started from the plan at the
    target's prior mean (on the
    shipped Helsinki world, warm from the nearest cluster's plan instead, 8 of 40 starts in
    one target's prior tail planned another route than the truth's from the same start), and a
    probe whose plan is only feasible adds its route as a certified one does: with every
    probe's plan marked ``feasible`` T1 still gets its west cluster (the test above)."""
    defaults = {"steps": 30, "trials": 10, "filter.motion": "commit", "filter.plan_clusters": 16,
                "filter.noise_scales": [0.003, 0.03, 0.3], "filter.loss_nats": 10.0, "filter.keep_out": True,
                "filter.route_probes": 32}
    sim = Simulation(load_mission(PAPER, defaults), "baseline")
    sim.reset(trial_seeds(2023, 1)[0])
    solve, probe, warms = sim.guidance.plan, Simulation._route_clusters, []

    def spied(self, j, *args):
        def uncertified(*a, **kw):
            if "warm" not in kw:  # the plan at the prior mean
                return solve(*a, **kw)
            warms.append((j, kw["warm"]))
            plan = solve(*a, **kw)
            return dataclasses.replace(plan, status="feasible") if plan.ok else plan

        self.guidance.plan = uncertified
        try:
            return probe(self, j, *args)
        finally:
            del self.guidance.plan

    monkeypatch.setattr(Simulation, "_route_clusters", spied)
    (_, _, _, live), *_ = sim.first_commit(16)
    assert len(warms) >= 4 * 32 - 8 and all(w is sim._prior_plan(j) for j, w in warms)
    assert (live.sum(axis=1) - 16)[0] == 1


def test_the_first_commits_capped_solves_count_in_every_trial_that_reuses_it(monkeypatch):
    """The first step's cluster plans are made once per guidance and reused by later trials;
    the solves the wall clock stopped while making them (here 3, added by hand) count in
    the trial that made them and again in each that reuses them, so every such trial says
    it may differ on another machine."""
    m = small(steps=1, **{"filter.motion": "commit"})
    sim = Simulation(m, "baseline")
    made = Simulation._cluster_plans

    def capped(self, *args):
        self.guidance.capped += 3
        return made(self, *args)

    monkeypatch.setattr(Simulation, "_cluster_plans", capped)
    counts = []
    for seed in (1, 2):
        before = sim.guidance.capped
        sim.reset(seed)
        sim.step()
        counts.append(sim.guidance.capped - before)
    assert counts == [3, 3]
