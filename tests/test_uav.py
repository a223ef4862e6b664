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
