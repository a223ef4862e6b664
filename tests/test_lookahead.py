"""The non-myopic ``lookahead`` policy: its score, its pruning, its registry entry."""

from dataclasses import replace

import numpy as np

from uavsim.belief.particle import ParticleBelief
from uavsim.belief.traces import gaussian_traces
from uavsim.bounds.pcrlb import information_reduction_factor
from uavsim.config import load_mission
from uavsim.targets import HORIZONTAL
from uavsim.uav import POLICIES, Lookahead, LookaheadConfig, admissible, make_policy

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


def test_one_scan_is_eq13_on_gaussian_beliefs():
    """One scan of the recursion is Eq. (13) for Gaussian beliefs: the trace after one
    noise-free bearing, linearised at the mean (:func:`gaussian_traces`), here on
    [x, y, vx, vy] and with the noise sigma^2 / q2 of a scan with misses and clutter."""
    pol, m = policy(1)
    b = belief(m)
    cands, ok = pol.moves()
    mean, cov = b.moments()
    cov4 = cov[np.ix_(range(len(mean)), HORIZONTAL, HORIZONTAL)]
    got = pol.traces_after(cov4[None], mean[:, :2], cands[None])[0]
    q2 = information_reduction_factor(m.sensor.sigma, m.sensor.p_detect, m.sensor.clutter_rate)
    mean4 = np.zeros_like(mean)
    mean4[:, :2] = mean[:, :2]
    cov6 = np.zeros_like(cov)
    cov6[:, :4, :4] = cov4  # [x, y, vx, vy] in the slots gaussian_traces reads as x, y, ...
    want = gaussian_traces(cands, mean4, cov6, m.sensor, info_factor=q2).sum(axis=1)
    np.testing.assert_allclose(got, want, rtol=1e-12)


def test_two_steps_by_hand():
    """Horizon 2, one target, from one start: the rollout's second move is the admissible
    grid move of least trace after its scan, found here by brute force in information
    form (J1 = P0^-1 + q2 h1'h1 / s^2, P2 = A J1^-1 A' + Q, J2 = P2^-1 + q2 h2'h2 / s^2,
    the score tr J2^-1), with the means moving by A (no plan)."""
    pol, m = policy(2)
    mean = np.array([[300.0, 700.0, 0.0, 3.0, -4.0, 0.0]])
    cov = np.diag([400.0, 250.0, 1e-6, 9.0, 16.0, 1e-6])[None]
    start = np.array([100.0, 100.0, m.uav.altitude])
    q2 = information_reduction_factor(m.sensor.sigma, m.sensor.p_detect, m.sensor.clutter_rate)
    r = m.sensor.sigma**2 / q2
    a, q = pol.a, pol.q

    def info(centre, s):
        d = centre - s[:2]
        h = np.array([d[1], -d[0], 0, 0]) / (d @ d)
        return np.outer(h, h) / r

    c0, c1 = mean[0, :2], mean[0, :2] + m.dynamics.dt * mean[0, 3:5]
    j1 = np.linalg.inv(cov[0][np.ix_(HORIZONTAL, HORIZONTAL)]) + info(c0, start)
    p2 = a @ np.linalg.inv(j1) @ a.T + q
    moves = start + pol.offsets
    assert admissible(start, moves, m.world, m.uav).all()  # far from every wall: the brute force needs no mask
    want = np.array([np.trace(np.linalg.inv(np.linalg.inv(p2) + info(c1, s))) for s in moves])
    centres = pol.predicted_means(mean)[..., :2]
    np.testing.assert_allclose(centres[1, 0], c1)
    after0 = pol.scan(cov[:, HORIZONTAL][:, :, HORIZONTAL][None], centres[0], start[None], predict=False)
    total, path = pol.rollout(start[None], after0, centres)
    np.testing.assert_allclose(total, [want.min()], rtol=1e-9)
    np.testing.assert_array_equal(path[0, 1], moves[np.argmin(want)])


def test_predicted_means_follow_the_plan_then_coast():
    """The plan was made from another estimate (offset 15 m, 2 m/s): the predicted means
    are the belief's mean driven by the plan's controls u_1 .. u_(T-1) and then by none,
    computed here by stepping the dynamics (Eq. 1 without noise)."""
    pol, m = policy(6)
    dyn = m.dynamics
    rng = np.random.default_rng(3)
    controls = rng.uniform(-4000.0, 4000.0, (4, 3))  # T = 4 < horizon 6
    controls[:, 2] = 0.0
    plan = [dyn.step(np.array([200.0, 300.0, 0.0, 4.0, -1.0, 0.0]), controls[0])]
    for u in controls[1:]:
        plan.append(dyn.step(plan[-1], u))
    mean = plan[0] + np.array([15.0, -15.0, 0.0, 2.0, 2.0, 0.0])
    want = [mean]
    for k in range(1, 6):
        want.append(dyn.step(want[-1], controls[k] if k < 4 else np.zeros(3)))
    got = pol.predicted_means(mean[None], [np.array(plan)])
    np.testing.assert_allclose(got[:, 0], np.array(want)[:, HORIZONTAL], rtol=1e-12, atol=1e-9)


def test_rollout_paths_are_admissible():
    """From 30 m west of the paper world's first obstacle with a target beyond it, every
    rolled-out move stays in the area and out of the obstacles, and no segment crosses one."""
    pol, m = policy(8)
    w = m.world
    lo, hi = w.obstacle_lo[0], w.obstacle_hi[0]
    start = np.array([lo[0] - 30.0, (lo[1] + hi[1]) / 2, m.uav.altitude])
    mean = np.array([[hi[0] + 60.0, start[1], 0.0, 0.0, 0.0, 0.0]])
    cov = np.diag([400.0, 400.0, 1e-6, 9.0, 9.0, 1e-6])[None]
    firsts = start + pol.offsets
    firsts = firsts[pol.m.world.in_area(firsts) & ~w.in_obstacle(firsts) & ~w.segment_blocked(start, firsts)]
    centres = pol.predicted_means(mean)[..., :2]
    p0 = np.broadcast_to(cov[:, HORIZONTAL][:, :, HORIZONTAL], (len(firsts), 1, 4, 4))
    _, paths = pol.rollout(firsts, pol.scan(p0, centres[0], firsts, predict=False), centres)
    assert w.in_area(paths).all() and not w.in_obstacle(paths).any()
    assert not w.segment_blocked(paths[:, :-1], paths[:, 1:]).any()
    assert np.ptp(paths[:, :, 0]) > 0  # the paths do move


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


def test_a_hidden_mean_gains_nothing_in_the_recursion():
    """Under line of sight a scan from where a predicted mean is hidden leaves its
    covariance as predicted, and one from where it is seen is the scan without line of
    sight: here the paper's world with the UAV at ground level behind an obstacle."""
    m0 = load_mission(PAPER)
    m = replace(m0, sensor=replace(m0.sensor, line_of_sight=True, world=m0.world))
    pol, plain = make_policy("lookahead", m), make_policy("lookahead", m0)
    w = m.world
    lo, hi = w.obstacle_lo[0], w.obstacle_hi[0]
    centre = (lo[:2] + hi[:2]) / 2
    behind = np.array([[centre[0], hi[1] + 30.0], [centre[0], lo[1] - 30.0]])  # north of it; south of it
    at = np.array([[centre[0], lo[1] - 20.0, 1.0]])  # the UAV south of the obstacle, below its roof
    assert pol.seen(behind, at[:, None, :]).ravel().tolist() == [0.0, 1.0]
    cov = np.broadcast_to(np.diag([100.0, 100, 4, 4]), (1, 2, 4, 4)).copy()
    after, without = pol.scan(cov, behind, at, predict=False), plain.scan(cov, behind, at, predict=False)
    np.testing.assert_array_equal(after[0, 0], cov[0, 0])
    np.testing.assert_allclose(after[0, 1], without[0, 1], rtol=1e-12)
    assert np.trace(after[0, 1]) < np.trace(cov[0, 1])
