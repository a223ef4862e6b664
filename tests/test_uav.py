"""UAV moves ([Papaioannou2023, Eq. (3)]) and their admission, counted by hand."""

import numpy as np

from uavsim.config import UavConfig, load_mission
from uavsim.uav import admissible, candidates, move_offsets
from uavsim.world import Region2D, World

from .conftest import PAPER


def world_with(boxes):
    lo = np.array([b[0] for b in boxes]).reshape(-1, 3)
    hi = np.array([b[1] for b in boxes]).reshape(-1, 3)
    return World("t", np.zeros(3), np.full(3, 1000.0), lo, hi, tuple(f"o{i}" for i in range(len(lo))), ())


def paper_uav(start, region=None):
    return UavConfig(start=np.array(start, float), step=5.0, n_theta=15, n_r=4, altitude=40.0, region=region)


def n_admissible(world, uav):
    c = candidates(uav.start, uav)
    return int(admissible(uav.start, c, world, uav).sum())


def test_offsets_paper_grid():
    off = move_offsets(5.0, 15, 4)
    assert off.shape == (61, 2)  # 1 stay + N_r * N_theta
    np.testing.assert_array_equal(off[0], [0, 0])
    assert len(np.unique(np.round(off, 9), axis=0)) == 61
    np.testing.assert_allclose(np.linalg.norm(off[1:], axis=1), np.repeat([5, 10, 15, 20], 15))
    # kappa = 1 of the first ring: Delta_theta = 24 deg from +x, counter-clockwise (Eq. 3)
    np.testing.assert_allclose(off[1], [5 * np.cos(np.radians(24)), 5 * np.sin(np.radians(24))])


def test_free_space_keeps_all_61():
    assert n_admissible(world_with([]), paper_uav([500, 500, 40])) == 61


def test_obstacle_12m_east():
    """Obstacle A's west face is 12 m east of the UAV.  A move of length r at angle a
    reaches it when r cos a >= 12: ring 3 (15 m) at 0, +-24 deg (cos >= 0.8), ring 4
    (20 m) at 0, +-24, +-48 deg (cos >= 0.6); rings 1-2 never.  61 - 3 - 5 = 53."""
    world = world_with([([300, 450, 0], [450, 600, 60])])
    assert n_admissible(world, paper_uav([288, 500, 40])) == 53


def test_thin_wall_is_caught_by_the_segment_test():
    """A 1 m wall at x in [310, 311], UAV at x = 300.  Blocked: r cos a >= 10 (ends on,
    in or beyond the wall): ring 2 at 0 deg (ends on the face), ring 3 at 0, +-24, +-48
    (15 cos 48 = 10.04, inside), ring 4 at 0, +-24, +-48.  Of these eleven, eight (ring 3
    at 0, +-24; all five of ring 4) end beyond the wall and only the segment test removes
    them.  61 - 11 = 50."""
    world = world_with([([310, 0, 0], [311, 1000, 100])])
    uav = paper_uav([300, 500, 40])
    c = candidates(uav.start, uav)
    ok = admissible(uav.start, c, world, uav)
    assert int(ok.sum()) == 50
    beyond = c[:, 0] > 311
    assert int((~ok & beyond).sum()) == 8
    assert not world.in_obstacle(c[~ok & beyond]).any()


def test_area_edge_2m_away():
    """UAV 2 m east of the area's west edge: a move leaves when r cos a < -2:
    rings 1-3 at 120..240 deg (6 each), ring 4 also at 96 and 264 deg (cos = -0.1045,
    20 * -0.1045 = -2.09): 6 + 6 + 6 + 8 = 26 removed, 35 left."""
    assert n_admissible(world_with([]), paper_uav([2, 500, 40])) == 35


def test_operating_region_box():
    """Region y <= 500 with the UAV on its edge: moves with sin a > 0 leave.  Angles
    24..168 deg (7 of 15) per ring; 61 - 4 * 7 = 33."""
    region = Region2D.box(np.array([0.0, 0.0]), np.array([1000.0, 500.0]))
    assert n_admissible(world_with([]), paper_uav([500, 500, 40], region)) == 33


def test_paper_start_all_admissible():
    m = load_mission(PAPER)
    assert n_admissible(m.world, m.uav) == 61


def test_weighted_counts_each_target_by_its_largest_trace_over_the_moves():
    """Hand-made traces (3 moves x 2 targets): Eq. (13) takes the least sum (ties to the
    lowest index); ``weighted`` weighs target j by its largest trace over the admissible
    moves, scaled to mean 1: weights (6, 8) / 7, scores (70, 70, 60) / 7, so move 2; an
    inadmissible move neither scores nor weighs."""
    from uavsim.uav import decide

    cands = np.zeros((3, 3))
    t = np.array([[5.0, 5.0], [1.0, 8.0], [6.0, 3.0]])
    every = np.ones(3, bool)
    best, scores = decide(cands, every, lambda c: t)
    assert best == 1 and scores.tolist() == [10.0, 9.0, 9.0]
    best, scores = decide(cands, every, lambda c: t, weighted=True)
    assert best == 2
    np.testing.assert_allclose(scores, [10.0, 10.0, 60.0 / 7.0])
    some = np.array([True, True, False])  # weights (5, 8) / 6.5: scores 65 / 6.5, 69 / 6.5
    best, scores = decide(cands, some, lambda c: t[some], weighted=True)
    assert best == 0 and scores[2] == np.inf
    np.testing.assert_allclose(scores[:2], [10.0, 69.0 / 6.5])
    best, scores = decide(cands, np.zeros(3, bool), lambda c: t, weighted=True)
    assert best == 0 and np.all(scores == np.inf)  # nothing admissible: the caller stays put


def test_the_weighted_policy_flies_to_its_best_score_in_the_closed_loop():
    """Three steps of the paper mission with ``--planner weighted``: each step the UAV
    stands at the candidate of least weighted score, and the scores are those
    :func:`decide` gives on the predicted belief (recomputed from the same traces)."""
    from uavsim.sim import Simulation
    from uavsim.uav import decide

    m = load_mission(PAPER, {"steps": 3, "filter.particles": 500})
    sim = Simulation(m, "weighted")
    sim.reset(7)
    for _ in range(3):
        sim.prepare()
        cands, ok = sim.policy.moves()
        want = decide(cands, ok, lambda c: sim.belief.traces(c, sim.policy.sensor), weighted=True)[1]
        info = sim.step()
        np.testing.assert_allclose(info.scores, want, rtol=1e-12)
        np.testing.assert_array_equal(info.uav, info.candidates[np.argmin(info.scores)])


class _Traces:
    """Two targets for the ``seek`` policy, their traces set by hand: target 0 below the UAV
    (trace 100; a move north leaves 88, any other 90), target 1 ``far`` metres east (trace
    1000; a bearing from within 6 m of it leaves ``left``)."""

    def __init__(self, uav, far, left):
        self.mean = np.zeros((2, 6))
        self.mean[0, :2], self.mean[1, :2] = uav[:2], uav[:2] + [far, 0.0]
        self.cov = np.stack([np.diag([50.0, 50, 0, 0, 0, 0]), np.diag([500.0, 500, 0, 0, 0, 0])])
        self.uav, self.left = np.asarray(uav, float), left

    def moments(self):
        return self.mean.copy(), self.cov.copy()

    def traces(self, c, sensor):
        near = np.where(c[:, 1] > self.uav[1] + 1.0, 88.0, 90.0)
        above = np.hypot(*(c[:, :2] - self.mean[1, :2]).T) < 6.0
        return np.column_stack([near, np.where(above, self.left, 1000.0)])


def test_seek_flies_to_a_far_target_when_its_bearing_pays_more_a_step():
    """Eq. (13)'s best move (north) gains 1100 - 1088 = 12 now.  From target 1's vantage, 5 m
    short of it, 600 m east, a bearing would leave 100 of its 1000: it gains 900 over
    ceil(595 / 20) = 30 steps of flight, 30 a step > 12, so ``seek`` takes the move nearest it: ring 4 due east
    (lam = 4, kap = 15, row 1 + 3 x 15 + 14 = 60).  Leaving 800 (200 over 30 steps, 6.7 a
    step) it keeps Eq. (13)'s move (row 1: the moves north tie, the lowest index wins); so it
    does with target 1 within one step, 15 m east, where Eq. (13)'s move is the first within
    6 m of it (ring 2 due east, row 1 + 15 + 14 = 30).  With a forecast it heads where the
    plan puts target 1 on arrival (due south: ring 4 at 264 deg, the nearest grid angle)."""
    from uavsim.uav import Seek

    m = load_mission(PAPER)
    pos = np.array([200.0, 150.0, 40.0])  # clear of the paper's obstacles, every move admissible
    policy = Seek(m)

    def move(far, left, forecast=None):
        policy.position = pos.copy()
        cands, scores, best = policy.choose(_Traces(pos, far, left), forecast)
        return best, cands[best] - pos

    best, step = move(600.0, 100.0)
    assert best == 60
    np.testing.assert_allclose(step, [20.0, 0.0, 0.0], atol=1e-9)
    best, step = move(600.0, 800.0)
    assert best == 1  # Eq. (13)'s: the moves north tie at 88, the lowest index (ring 1 at 24 deg) wins
    best, step = move(15.0, 100.0)
    assert best == 30  # Eq. (13)'s: rings 2 and 3 due east tie at 190, the lower index wins
    plan = np.zeros((40, 6))
    plan[:, :2] = pos[:2] + [600.0, 0.0]
    plan[30:, :2] = pos[:2] + [0.0, -600.0]  # on arrival (step 30) target 1 is due south
    best, step = move(600.0, 100.0, [None, plan])
    np.testing.assert_allclose(step, [20 * np.cos(np.radians(264)), 20 * np.sin(np.radians(264)), 0.0], atol=1e-9)


class _Hidden(_Traces):
    """:class:`_Traces` with both targets hidden from every move (each leaves 100 and 1000,
    so Eq. (13) ties everywhere); a bearing from within 6 m of target 1 leaves ``left``."""

    def traces(self, c, sensor):
        above = np.hypot(*(c[:, :2] - self.mean[1, :2]).T) < 6.0
        return np.column_stack([np.full(len(c), 100.0), np.where(above, self.left, 1000.0)])


def test_moves_that_tie_in_eq_13_are_broken_toward_the_flight_that_pays():
    """Every move leaves 1100, so Eq. (13)'s lowest index is "stay", for good: the UAV would
    learn nothing (as on a Helsinki crop where no move saw a target).  Target 1's vantage,
    600 m east, gains 900 over 30 steps (target 0's, where the UAV is, gains nothing), so
    ``optimized`` and ``weighted`` take the tied move nearest target 1: ring 4 due east (row
    60); with a forecast, the one nearest where the plan puts it on arrival (due south: ring 4
    at 264 deg).  Hidden from its vantage too (it leaves 1000 there), no flight gains and they
    stay (row 0)."""
    from uavsim.uav import GridOptimizer, Weighted

    m = load_mission(PAPER)
    pos = np.array([200.0, 150.0, 40.0])  # clear of the paper's obstacles, every move admissible
    plan = np.zeros((40, 6))
    plan[:, :2] = pos[:2] + [600.0, 0.0]
    plan[30:, :2] = pos[:2] + [0.0, -600.0]
    for policy in (GridOptimizer(m), Weighted(m)):
        policy.position = pos.copy()
        cands, scores, best = policy.choose(_Hidden(pos, 600.0, 100.0))
        assert np.ptp(scores) == 0 and best == 60
        np.testing.assert_allclose(cands[best] - pos, [20.0, 0.0, 0.0], atol=1e-9)
        cands, _, best = policy.choose(_Hidden(pos, 600.0, 100.0), [None, plan])
        np.testing.assert_allclose(cands[best] - pos, [20 * np.cos(np.radians(264)), 20 * np.sin(np.radians(264)), 0.0],
                                   atol=1e-9)
        assert policy.choose(_Hidden(pos, 600.0, 1000.0))[2] == 0


def test_a_step_where_every_move_ties_is_reported(monkeypatch):
    """:func:`every_move_ties` by hand: all admissible moves equal (an inadmissible one aside),
    yes; one higher, or fewer than two admissible, or no scores (a policy that does not score),
    no.  In the closed loop a step whose moves all tie says so in its events, once."""
    from uavsim.sim import Simulation
    from uavsim.uav.grid import GridOptimizer, every_move_ties

    assert every_move_ties(np.array([5.0, 5.0, 5.0 * (1 + 1e-12), np.inf]))
    assert not every_move_ties(np.array([5.0, 5.0, 6.0]))
    assert not every_move_ties(np.array([5.0, np.inf, np.inf]))
    assert not every_move_ties(None)

    def flat(self, t, belief, action=None, forecast=None):
        cands, ok = self.moves()
        return cands, np.where(ok, 1.0, np.inf)

    m = load_mission(PAPER, {"steps": 2, "filter.particles": 300})
    sim = Simulation(m, "optimized")
    sim.reset(1)
    monkeypatch.setattr(GridOptimizer, "act", flat)
    info = sim.step()
    assert sum(e.startswith("UAV: every admissible move ties") for e in info.events) == 1
