"""The route a committed particle flies: its cluster models, their Eq. (7) costs and the
cheapest clear choice (uavsim.belief.choice), and the depth grid it tests clearance on."""

import numpy as np
import pytest

from uavsim.belief import FilterConfig
from uavsim.belief.choice import CLEAR_TOL_M, cheapest, cluster_models, eq7_quadratic
from uavsim.belief.particle import nearest_clusters
from uavsim.declare import SettingError
from uavsim.sim import model_positions
from uavsim.targets import HORIZONTAL, Dynamics
from uavsim.world.model import Polygons
from uavsim.world.space import DepthGrid

DYN = Dynamics()


def random_plans(rng, k=3, t=12):
    means = rng.normal(0, 20, (k, 6))
    means[:, [2, 5]] = 0.0
    controls = rng.normal(0, 800, (k, t, 3))
    controls[..., 2] = 0.0
    gains = rng.normal(0, 50, (k, t, 3, 4))
    gains[:, :, 2] = 0.0
    return means, controls, gains


def test_cluster_models_are_the_flight_of_an_offset_start():
    """A start flown by a cluster's plan plus its gains times the offset (model_positions, a
    step-by-step simulation of Eq. (1)) is the cluster's flown mean plus S_t times the
    offset: the model is affine in the offset, to rounding."""
    rng = np.random.default_rng(3)
    means, controls, gains = random_plans(rng)
    states, sens = cluster_models(means, controls, gains, DYN)
    start = means[1] + np.array([7.0, -4.0, 0.0, 1.5, -0.5, 0.0])
    flown = model_positions(start, means, controls, gains, DYN)  # (K, T, 2)
    d = start[HORIZONTAL] - means[:, HORIZONTAL]
    model = states[..., :2] + np.einsum("ktij,kj->kti", sens[..., :2, :], d)
    assert np.allclose(model, flown, rtol=1e-10, atol=1e-8)
    assert np.allclose(model_positions(means[0], means[:1], controls[:1], gains[:1], DYN), states[:1, :, :2])


@pytest.mark.parametrize("link", [False, True])
def test_eq7_quadratic_is_eq7_of_the_flown_model(link):
    """``c + 2 g.d + d'Hd`` equals Eq. (7) evaluated on the model flown from the offset start:
    the terminal miss squared plus rho times the squared force steps (and, with the link
    term, the first force's step from zero)."""
    rng = np.random.default_rng(5)
    means, controls, gains = random_plans(rng)
    goal, rho = np.array([300.0, -150.0, 0.0]), 0.01
    states, sens = cluster_models(means, controls, gains, DYN)
    c, g, h = eq7_quadratic(states, sens, controls, gains, goal, rho, link)
    for kk in range(len(means)):
        d = rng.normal(0, 5, 4)
        start = means[kk].copy()
        start[HORIZONTAL] += d
        end = model_positions(start, means[kk:kk + 1], controls[kk:kk + 1], gains[kk:kk + 1], DYN)[0, -1]
        u = controls[kk, :, :2] + gains[kk, :, :2] @ d
        steps = np.diff(np.vstack([np.zeros((1, 2)), u]) if link else u, axis=0)
        direct = ((end - goal[:2]) ** 2).sum() + rho * (steps ** 2).sum()
        assert c[kk] + 2 * g[kk] @ d + d @ h[kk] @ d == pytest.approx(direct, rel=1e-9)


def test_depth_grid_by_hand():
    """Depths hand-derived: 2 m into a 10 x 4 m box from its long side at (5, 2), 1 m at
    (1, 1), none outside, 3 m into a triangle over its base; 10 m outside the area (and no
    more, the pad, 40 m outside); and a
    lookup between grid points within res / sqrt(2) of the exact depth."""
    box = np.array([[0, 0], [10, 0], [10, 4], [0, 4]])
    tri = np.array([[20, 20], [30, 20], [25, 30]])
    grid = DepthGrid.build(Polygons.from_list([box, tri]), np.array([-50, -50]), np.array([50, 50]), 0.5)
    got = grid(np.array([[5, 2], [1, 1], [11, 2], [25, 23], [60, 0], [-49, -49]]))
    assert np.allclose(got, [2, 1, 0, 3, 10, 0])
    assert grid(np.array([90.0, 0.0])) == pytest.approx(10.0)  # farther out reads the edge: pad, 10 m
    assert abs(grid(np.array([5.2, 1.3])) - 1.3) <= 0.5 / np.sqrt(2) + 1e-9


def test_cheapest_takes_the_clear_plan_and_else_the_nearest():
    """Two clusters with their means at the start (offset zero) and gains zero: cluster 0
    pushes east, cluster 1 north-east, for 10 steps; the goal lies on cluster 0's end, so
    Eq. (7) prefers it.  With nothing in the way it is chosen even when cluster 1 is the
    nearest; a box 10 m deep over cluster 0's path alone leaves cluster 1 though 0 is the
    nearest; a box over both paths leaves the nearest, whichever it is; a box that cluster
    0's path dips into by less than the tolerance keeps cluster 0.  With ``keep`` (the
    "clear" choice) the nearest is kept while its path is clear, however much cheaper
    another is, and a box over its path alone leaves the cheapest clear one."""
    t = 10
    means = np.zeros((2, 6))
    controls = np.zeros((2, t, 3))
    controls[0, :, 0] = 2000.0
    controls[1, :, :2] = 2000.0 / np.sqrt(2.0)
    gains = np.zeros((2, t, 3, 4))
    states, sens = cluster_models(means, controls, gains, DYN)
    quad = eq7_quadratic(states, sens, controls, gains, np.array([*states[0, -1, :2], 0.0]), 0.01, False)
    start = np.zeros((1, 6))
    lo, hi = np.array([-100.0, -100.0]), np.array([400.0, 400.0])

    def choose(order, polygons, keep=False):
        grid = DepthGrid.build(polygons, lo, hi)
        return int(cheapest(start, np.array([order]), means, states, sens, quad, grid, keep)[0])

    x = states[0, 5, 0]  # cluster 0's path at step 6; cluster 1's is then at y = x / sqrt(2) > 10 m
    assert states[1, 5, 1] > 12.0
    assert choose([1, 0], Polygons.from_list([])) == 0
    block = Polygons.boxes(np.array([[x - 5, -10.0]]), np.array([[x + 5, 10.0]]))
    assert choose([0, 1], block) == 1
    both = Polygons.boxes(np.array([[x - 5, -10.0]]), np.array([[x + 5, 200.0]]))
    assert choose([0, 1], both) == 0 and choose([1, 0], both) == 1
    shallow = Polygons.boxes(np.array([[x - 5, -20.0]]), np.array([[x + 5, CLEAR_TOL_M - 1.0]]))
    assert choose([1, 0], shallow) == 0
    assert choose([1, 0], Polygons.from_list([]), keep=True) == 1
    y = states[1, 5, :2]  # cluster 1's path at step 6, cluster 0's then 12 m or more below it
    on_1 = Polygons.boxes(np.array([y - 5]), np.array([y + 5]))
    assert choose([1, 0], on_1, keep=True) == 0 and choose([0, 1], on_1, keep=True) == 0


def test_nearest_clusters_order_and_dead_ones():
    """Candidates nearest first; a cluster without particles is never a candidate (the
    nearest live one repeats in its place)."""
    means = np.zeros((1, 3, 6))
    means[0, :, 0] = [5.0, 1.0, 3.0]
    p = np.zeros((1, 1, 6))
    live = np.ones((1, 3), bool)
    assert nearest_clusters(p, means, np.ones((1, 4)), live, 3)[0, 0].tolist() == [1, 2, 0]
    live[0, 2] = False
    assert nearest_clusters(p, means, np.ones((1, 4)), live, 3)[0, 0].tolist() == [1, 0, 1]


def test_route_choice_needs_committed_plans():
    """A choice other than the nearest chooses among committed plans: refused with re-planning."""
    assert FilterConfig().route_choice == "nearest"
    assert FilterConfig(route_choice="clear").route_choice == "clear"
    with pytest.raises(SettingError, match="route_choice"):
        FilterConfig(motion="replan", route_choice="cheapest")


def test_clear_moves_only_particles_whose_nearest_model_is_blocked():
    """In the loop (the paper's world, 8 committed clusters, 400 particles): "clear" moves a
    particle off its nearest cluster only where "cheapest" moves it too, and then to the same
    cluster (both take the cheapest clear model once the nearest is out), and "cheapest" moves
    more; every label is a live cluster; and a trial with either choice is the same,
    bit for bit, on a guidance that made its clusters and depth grid for another trial and on
    a fresh one (results do not depend on which worker ran which trial)."""
    from uavsim.belief.particle import join_clusters
    from uavsim.campaign import kept_guidance, run_trial, trial_seeds
    from uavsim.config import load_mission
    from uavsim.sim import Simulation

    from .conftest import PAPER

    base = {"steps": 2, "trials": 2, "filter.particles": 400, "filter.motion": "commit", "filter.plan_clusters": 8,
            "filter.noise_scales": [0.003, 0.03, 0.3], "filter.keep_out": True}
    seeds = trial_seeds(2023, 2)
    labels = {}
    for rule in ("cheapest", "clear"):
        m = load_mission(PAPER, base | {"filter.route_choice": rule})
        sim = Simulation(m, "optimized", kept_guidance(m))
        sim.reset(seeds[0])
        first = sim.first_commit(m.filter.plan_clusters)
        means, _, scale, live = first.reference
        nearest = join_clusters(sim.belief.pf.particles, means, scale, live)
        labels[rule] = sim._choose_routes(first)
        assert np.take_along_axis(live, labels[rule], axis=1).all()
        shared = run_trial(m, "optimized", 1, seeds[1], sim.guidance)
        fresh = run_trial(m, "optimized", 1, seeds[1])
        np.testing.assert_array_equal(shared.err2, fresh.err2)
        assert np.isfinite(shared.err2).all()
    moved = labels["clear"] != nearest
    assert moved.any() and (labels["cheapest"] != nearest).sum() > moved.sum()  # measured: 163 and 1229 of 1600
    assert (labels["cheapest"][moved] == labels["clear"][moved]).all()
