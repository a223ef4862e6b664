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
