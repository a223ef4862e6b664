"""The non-myopic ``lookahead`` policy (issue 18): its score, its pruning, its registry entry."""

from dataclasses import replace

import numpy as np

from uavsim.belief.particle import ParticleBelief
from uavsim.belief.traces import gaussian_traces
from uavsim.config import load_mission
from uavsim.pcrlb import information_reduction_factor
from uavsim.targets import HORIZONTAL
from uavsim.uav import POLICIES, Lookahead, LookaheadConfig, make_policy

from .conftest import PAPER


def belief(m, n=2000):
    """The mission's prior as a particle belief."""
    return ParticleBelief(np.random.default_rng(5), np.array([t.mean0 for t in m.targets]),
                          np.array([t.cov0 for t in m.targets]), n, 0.5, 0.0, tuple(t.name for t in m.targets))


def policy(horizon, **mission_changes):
    m = load_mission(PAPER)
    m = replace(m, planner=replace(m.planner, lookahead=LookaheadConfig(horizon)), **mission_changes)
    return make_policy("lookahead", m), m


def test_registered_and_read_from_the_mission():
    assert POLICIES["lookahead"] is Lookahead
    assert load_mission(PAPER).planner.lookahead.horizon == LookaheadConfig.horizon


def test_horizon_one_is_the_optimized_policy():
    """With one step the score is the first step's term alone: Eq. (13) on the belief."""
    pol, m = policy(1)
    b = belief(m)
    cands, scores, best = pol.choose(b)
    _, want, want_best = make_policy("optimized", m).choose(b)
    np.testing.assert_array_equal(scores, want)
    assert best == want_best


def test_one_step_of_the_recursion_is_eq13_on_gaussian_beliefs():
    """One step of the recursion is Eq. (13) for Gaussian beliefs: the trace after one
    noise-free bearing, linearised at the mean (:func:`gaussian_traces`), here on
    [x, y, vx, vy] and with the noise sigma^2 / q2 of a scan with misses and clutter."""
    pol, m = policy(1)
    b = belief(m)
    cands, ok = pol.moves()
    mean, cov = b.moments()
    got = pol.scores(pol.paths(cands)[:, 0], mean, cov)
    q2 = information_reduction_factor(m.sensor.sigma, m.sensor.p_detect, m.sensor.clutter_rate)
    mean4 = np.zeros_like(mean)
    mean4[:, :2] = mean[:, :2]
    cov6 = np.zeros_like(cov)
    # [x, y, vx, vy] in the slots gaussian_traces reads as x, y, ...
    cov6[:, :4, :4] = cov[np.ix_(range(len(mean)), HORIZONTAL, HORIZONTAL)]
    want = gaussian_traces(cands, mean4, cov6, m.sensor.sigma / np.sqrt(q2)).sum(axis=1)
    np.testing.assert_allclose(got, want, rtol=1e-12)


def test_two_steps_equal_the_information_recursion():
    """Hand check of the two-step recursion for one target and one path, in information
    form: J1 = P0^-1 + q2 h1'h1 / s^2, P2 = (A J1^-1 A' + Q), J2 = P2^-1 + q2 h2'h2 / s^2;
    the score is tr J1^-1 + tr J2^-1."""
    pol, m = policy(2)
    mean = np.array([[300.0, 700.0, 0.0, 3.0, -4.0, 0.0]])
    cov = np.diag([400.0, 250.0, 1e-6, 9.0, 16.0, 1e-6])[None]
    path = np.array([[[100.0, 100.0, 40.0], [120.0, 110.0, 40.0]]])
    q2 = information_reduction_factor(m.sensor.sigma, m.sensor.p_detect, m.sensor.clutter_rate)
    r = m.sensor.sigma**2 / q2
    a, q = pol.a, pol.q

    def info(centre, s):
        d = centre - s[:2]
        h = np.array([d[1], -d[0], 0, 0]) / (d @ d)
        return np.outer(h, h) / r

    p0 = cov[0][np.ix_(HORIZONTAL, HORIZONTAL)]
    c0 = mean[0, :2]
    j1 = np.linalg.inv(p0) + info(c0, path[0, 0])
    j2 = np.linalg.inv(a @ np.linalg.inv(j1) @ a.T + q) + info(c0 + m.dynamics.dt * mean[0, 3:5], path[0, 1])
    want = np.trace(np.linalg.inv(j1)) + np.trace(np.linalg.inv(j2))
    np.testing.assert_allclose(pol.scores(path, mean, cov), [want], rtol=1e-9)


def test_paths_stop_before_an_obstacle():
    """From 30 m west of the paper world's first obstacle, the continuation heading east
    (20 m steps) would enter it at its 2nd step: the path stays at its 1st (10 m short of
    the wall) from then on; no path enters or crosses an obstacle."""
    pol, m = policy(8)
    w = m.world
    lo, hi = w.obstacle_lo[0], w.obstacle_hi[0]
    pol.position = np.array([lo[0] - 30.0, (lo[1] + hi[1]) / 2, m.uav.altitude])
    paths = pol.stop_at_limits(pol.paths(pol.position[None]))[0]  # (V, H, 3)
    east = np.argmin(np.abs(pol.continuations[1:, 1])) + 1  # the continuation along +x
    np.testing.assert_allclose(paths[east, 1:, 0], lo[0] - 10.0)
    assert not w.in_obstacle(paths).any() and not w.segment_blocked(paths[:, :-1], paths[:, 1:]).any()
    np.testing.assert_array_equal(paths[0], np.repeat(pol.position[None], 8, axis=0))  # "stay" stays


def test_choice_is_admissible_and_scores_only_admissible_moves():
    pol, m = policy(8)
    cands, scores, best = pol.choose(belief(m))
    _, ok = pol.moves()
    assert np.isfinite(scores[ok]).all() and np.isinf(scores[~ok]).all()
    assert ok[best] and scores[best] == scores.min()


def test_no_detections_leave_only_the_first_step():
    """p_D = 0: later scans carry no information (q2 = 0), so every path adds the same
    later terms and the choice is Eq. (13)'s."""
    m0 = load_mission(PAPER)
    pol, m = policy(4, sensor=replace(m0.sensor, p_detect=0.0))
    b = belief(m)
    _, scores, best = pol.choose(b)
    _, first, first_best = make_policy("optimized", m).choose(b)
    ok = np.isfinite(first)
    assert best == first_best
    assert np.ptp(scores[ok] - first[ok]) <= 1e-9 * scores[ok].max()
