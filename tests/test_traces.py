"""The pseudo-posterior traces (belief/traces.py, [Papaioannou2023] Eq. 12) and the UAV's
decision on them (uav/grid.py, Eq. 13), against a plain float64 loop and by geometry."""

import math

import numpy as np
import pytest

from uavsim.belief.traces import bearing_traces
from uavsim.estimators import angles
from uavsim.sensing import BearingModel, bearing, wrap_angle
from uavsim.uav import decide, move_offsets

SIGMA = math.radians(1.0)


def brute_force(cands, particles, weights, sigma):
    """Eq. (12) then Eq. (11), one candidate and one target at a time, in float64."""
    out = np.zeros((len(cands), len(particles)))
    for c, s in enumerate(cands):
        for j, (x, w) in enumerate(zip(particles, weights)):
            mu = w @ x
            z = bearing(mu, s)  # Eq. (12): noise-free bearing of the predicted mean
            lik = np.exp(-0.5 * (wrap_angle(z - bearing(x, s)) / sigma) ** 2)
            wt = w * lik / np.sum(w * lik)
            m = wt @ x
            out[c, j] = np.sum(wt @ (x - m) ** 2)  # trace of the weighted covariance
    return out


def cloud(rng, centres, n, spread):
    return centres[:, None, :] + rng.normal(size=(len(centres), n, 6)) * spread


@pytest.fixture(params=[False, True], ids=["polynomial", "numpy-arctan2"])
def angle_path(request, monkeypatch):
    """Both ways the residual angles are taken (:mod:`uavsim.estimators.angles`), whichever this CPU uses."""
    monkeypatch.setattr(angles, "ARCTAN2_VECTORISED", request.param)


def test_traces_and_choice_match_the_loop(angle_path):
    rng = np.random.default_rng(3)
    centres = np.array([[300.0, 700, 0, 5, -5, 0], [820, 610, 0, -3, -8, 0]])
    particles = cloud(rng, centres, 400, np.sqrt([200, 200, 1e-10, 20, 20, 1e-10]))
    weights = rng.dirichlet(np.ones(400), size=2)
    cands = np.column_stack([np.array([450.0, 300.0]) + move_offsets(5.0, 15, 4), np.full(61, 40.0)])
    want = brute_force(cands, particles, weights, SIGMA)
    got = bearing_traces(cands, particles, weights, SIGMA)
    np.testing.assert_allclose(got, want, rtol=1e-5)  # float32 kernel on centred particles
    ok = np.ones(61, bool)
    ok[[5, 17]] = False
    best, total = decide(cands, ok, lambda c: bearing_traces(c, particles, weights, SIGMA))
    masked = np.where(ok, want.sum(1), np.inf)
    assert best == int(np.argmin(masked)) and np.isinf(total[[5, 17]]).all()


def test_blocks_over_particles_add_up_to_the_loop(angle_path):
    """3001 particles in blocks of BLOCK_ELEMENTS / (61 x 2) = 537 (the last one short).
    Target 0 is spread across the line of sight (sd 200 m at ~640 m, ~17 deg) and stored
    sorted by x, so the outer blocks hold no particle within 13 sigma of the mean's
    bearing: their own sums are taken relative to their best particle and must be
    scaled down (to 0 in float64 for the outermost) when the blocks are added."""
    from uavsim.belief.traces import BLOCK_ELEMENTS

    rng = np.random.default_rng(8)
    n = 3001
    assert BLOCK_ELEMENTS // (61 * 2) < n
    wide = cloud(rng, np.array([[530.0, 700, 0, 5, -5, 0]]), n, np.sqrt([4e4, 200, 1e-10, 20, 20, 1e-10]))[0]
    narrow = cloud(rng, np.array([[820.0, 610, 0, -3, -8, 0]]), n, np.sqrt([200, 200, 1e-10, 20, 20, 1e-10]))[0]
    particles = np.stack([wide[np.argsort(wide[:, 0])], narrow])
    weights = rng.dirichlet(np.ones(n), size=2)
    cands = np.column_stack([np.array([530.0, 60.0]) + move_offsets(5.0, 15, 4), np.full(61, 40.0)])
    np.testing.assert_allclose(bearing_traces(cands, particles, weights, SIGMA),
                               brute_force(cands, particles, weights, SIGMA), rtol=1e-5)


def test_ties_go_to_the_lowest_index():
    rng = np.random.default_rng(4)
    particles = cloud(rng, np.array([[500.0, 500, 0, 0, 0, 0]]), 200, 10.0)
    weights = np.full((1, 200), 1 / 200)
    cands = np.tile([[100.0, 100.0, 40.0]], (5, 1))
    ok = np.array([False, True, True, True, True])
    assert decide(cands, ok, lambda c: bearing_traces(c, particles, weights, SIGMA))[0] == 1


def test_moving_across_the_line_of_sight_beats_moving_along_it():
    """A target 100 m north, its uncertainty along the line of sight (range, sd 30 m) and
    narrow across it (sd 0.1 m).  From 20 m east the bearing changes by 20 / (100^2 + 20^2)
    = 1.9e-3 rad (0.11 deg) per metre of range, so the range spread shows as about
    +-3.3 deg, well above sigma = 1 deg: that bearing cuts the range uncertainty (measured:
    the trace falls by 91%).  From 20 m north (along the line of sight) the bearings differ
    by at most ~0.1 m / 80 m = 0.07 deg, far below sigma: the trace barely moves (4%)."""
    rng = np.random.default_rng(6)
    particles = cloud(rng, np.array([[0.0, 100, 0, 0, 0, 0]]), 4000, np.array([0.1, 30, 0, 0.1, 0.1, 0]))
    weights = np.full((1, 4000), 1 / 4000)
    cands = np.array([[0.0, 20.0, 40.0], [20.0, 0.0, 40.0], [-20.0, 0.0, 40.0]])
    traces = bearing_traces(cands, particles, weights, SIGMA)[:, 0]
    prior = np.trace(np.cov(particles[0].T, bias=True))
    assert traces[1] < 0.2 * prior and traces[2] < 0.2 * prior
    assert traces[0] > 0.9 * prior
    assert np.argmin(traces) in (1, 2)


def test_gaussian_traces_by_hand():
    """P = a I, candidate r = 200 m away: |h| = 1 / r, so the trace drops by
    a^2 / r^2 / (a / r^2 + sigma^2) (Eq. 12-13 linearised; pseudo-linear filters)."""
    from uavsim.belief.traces import gaussian_traces

    a, r, sigma = 25.0, 200.0, 0.02
    means = np.array([[300.0, 400.0, 0, 1, 2, 0]])
    cands = np.array([[300.0, 200.0, 40.0], [300.0 + r, 400.0, 40.0]])
    got = gaussian_traces(cands, means, a * np.eye(6)[None], BearingModel(sigma))
    want = 6 * a - a**2 / r**2 / (a / r**2 + sigma**2)
    np.testing.assert_allclose(got[:, 0], [want, want], rtol=1e-12)


def test_gaussian_traces_right_above_a_mean_score_no_measurement():
    """Within ``MIN_RANGE_M`` (1 m) of a mean the range is floored: 0.5 m north of it
    ``|h| = 0.5 / 1^2``, so the trace drops by ``a^2 0.25 / (0.25 a + sigma^2)``; right above
    it ``h = 0`` and the trace is the prediction's, ``6 a``, where the bearing's gradient
    ``(dy, -dx) / r^2`` is undefined (a Gaussian-belief run whose UAV started above a
    target's prior mean stopped with a ValueError there)."""
    from uavsim.belief.traces import gaussian_traces

    a, sigma = 25.0, 0.02
    means = np.array([[300.0, 400.0, 0, 1, 2, 0]])
    cands = np.array([[300.0, 399.5, 40.0], [300.0, 400.0, 40.0]])
    got = gaussian_traces(cands, means, a * np.eye(6)[None], BearingModel(sigma))
    np.testing.assert_allclose(got[:, 0], [6 * a - a**2 * 0.25 / (0.25 * a + sigma**2), 6 * a], rtol=1e-12)
