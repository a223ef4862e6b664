"""World geometry ([Papaioannou2023, Sec. III-D, Eq. (5)]): hand-derived points and segments."""

import numpy as np
import pytest

from uavsim.world import (
    Region2D,
    cuboid_halfspaces,
    free_space,
    ground_footprints,
    inside_polytopes,
    label_grid,
    segments_hit_polytopes,
)

LO, HI = np.array([1.0, 2.0, 0.0]), np.array([3.0, 5.0, 4.0])


def unit_box():
    return cuboid_halfspaces(np.zeros(3), np.ones(3))


def test_halfspaces_by_hand():
    a, b = cuboid_halfspaces(LO, HI)
    assert a.shape == (1, 6, 3) and b.shape == (1, 6)
    np.testing.assert_array_equal(a[0], [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]])
    np.testing.assert_array_equal(b[0], [3, -1, 5, -2, 4, 0])
    np.testing.assert_array_equal(np.linalg.norm(a[0], axis=1), 1.0)


def test_points_on_inside_and_just_outside_every_face():
    a, b = cuboid_halfspaces(LO, HI)
    centre = (LO + HI) / 2
    on_faces, outside = [], []
    for axis in range(3):
        for bound, sign in ((LO, -1), (HI, +1)):
            p = centre.copy()
            p[axis] = bound[axis]
            on_faces.append(p)
            q = p.copy()
            q[axis] += sign * 1e-9
            outside.append(q)
    pts = np.array([centre, *on_faces, *outside])
    inside = inside_polytopes(pts, a, b)[:, 0]
    assert inside[0]  # strictly inside
    assert inside[1:7].all()  # on a face counts as inside: obstacles are closed
    assert not inside[7:].any()  # 1 nm beyond any face: Eq. (5) holds
    # corners and edges are on three / two faces at once
    assert inside_polytopes(np.array([LO, HI, [3.0, 5.0, 2.0]]), a, b).all()


@pytest.mark.parametrize(
    "p0, p1, hit",
    [
        ([0.4, -0.5, 0.5], [1.4, 0.5, 0.5], True),  # cuts the corner (1, 0): y = x - 0.9
        ([0.6, -0.5, 0.5], [1.6, 0.5, 0.5], False),  # passes it: y = x - 1.1 never enters
        ([0.5, -0.5, 0.5], [1.5, 0.5, 0.5], True),  # touches the corner edge exactly
        ([-1.0, 0.5, 0.5], [2.0, 0.5, 0.5], True),  # through, both ends outside
        ([-1.0, 0.5, 1.5], [2.0, 0.5, 1.5], False),  # over the top
        ([-1.0, 0.5, 1.0], [2.0, 0.5, 1.0], True),  # grazes the top face
        ([0.5, 0.5, 0.5], [0.5, 0.5, 0.5], True),  # a point inside
        ([-0.5, 0.5, 0.5], [-0.1, 0.5, 0.5], False),  # ends before the -x face
        ([-0.5, 0.5, 0.5], [0.0, 0.5, 0.5], True),  # ends on the -x face
    ],
)
def test_segment_cases_by_hand(p0, p1, hit):
    a, b = unit_box()
    got = segments_hit_polytopes(np.array(p0), np.array(p1), a, b)
    assert got.shape == (1,) and got[0] == hit


def test_segments_agree_with_dense_sampling():
    """Random segments: every sampled inside point implies a hit, and every hit has a
    sample within one sampling step of the box."""
    rng = np.random.default_rng(7)
    a, b = unit_box()
    p0 = rng.uniform(-1.5, 2.5, (4000, 3))
    p1 = rng.uniform(-1.5, 2.5, (4000, 3))
    hit = segments_hit_polytopes(p0, p1, a, b)[:, 0]
    s = np.linspace(0, 1, 2001)
    pts = p0[:, None, :] + s[None, :, None] * (p1 - p0)[:, None, :]
    sampled_in = inside_polytopes(pts, a, b)[..., 0].any(axis=1)
    assert np.all(hit[sampled_in])
    dist = np.linalg.norm(np.maximum(0, np.maximum(-pts, pts - 1)), axis=-1).min(axis=1)
    step = np.linalg.norm(p1 - p0, axis=1) / 2000
    assert np.all(dist[hit] <= step[hit] + 1e-12)
    assert 0.1 < hit.mean() < 0.9  # the sample exercises both outcomes


def test_region_polygon_and_box():
    tri = Region2D.from_vertices(np.array([[0.0, 0.0], [4.0, 0.0], [0.0, 4.0]]))
    pts = np.array([[1, 1, 40], [2, 2, 40], [2.01, 2, 40], [-0.01, 1, 40]])
    np.testing.assert_array_equal(tri.contains(pts), [True, True, False, False])
    box = Region2D.box(np.array([0.0, 0.0]), np.array([2.0, 1.0]))
    np.testing.assert_array_equal(box.contains(np.array([[2, 1], [2.1, 0.5], [1, -0.1]])), [True, False, False])


# --------------------------------------------------------------------------- ground free space
AREA_LO, AREA_HI = np.array([0.0, 0.0]), np.array([100.0, 100.0])


def test_ground_footprints_by_hand():
    """margin 9, band 1: kept when z_min - 9 < -1 and z_max + 9 > 1 ([Papaioannou2023] via the guidance model)."""
    lo = np.array([[0, 0, 0], [0, 0, 5], [0, 0, 15], [0, 0, -30], [0, 0, 7.9]], dtype=float)
    hi = np.array([[10, 20, 60], [10, 20, 60], [10, 20, 60], [10, 20, -12], [10, 20, 60]], dtype=float)
    kept, f_lo, f_hi = ground_footprints(lo, hi, 9.0)
    np.testing.assert_array_equal(kept, [0, 1, 4])
    np.testing.assert_array_equal(f_lo, [[-9, -9]] * 3)
    np.testing.assert_array_equal(f_hi, [[19, 29]] * 3)


def _space(rects, regions=()):
    r = np.array(rects, dtype=float).reshape(-1, 4)
    return free_space(r[:, :2], r[:, 2:], AREA_LO, AREA_HI, regions)


GOAL = (np.array([80.0, 45.0]), np.array([90.0, 55.0]))


@pytest.mark.parametrize("rects, connected", [
    ([[40, 0, 60, 45], [40, 55, 60, 100]], True),  # a wall with a 10 m corridor
    ([[40, 0, 60, 49.9], [40, 50, 60, 100]], True),  # a 0.1 m corridor is still a corridor
    ([[40, 0, 60, 50], [40, 50, 60, 100]], False),  # the walls touch along y = 50: closed
    ([[40, 0, 60, 50], [40, 40, 60, 100]], False),  # the walls overlap
    ([[40, 0, 60, 100]], False),  # one wall touching the area's bottom and top edges
    ([[40, 0.1, 60, 100]], True),  # 0.1 m left between the wall and the area's edge
    ([[40, 0, 50, 50], [50, 50, 60, 100]], False),  # touching at the corner (50, 50) only
    ([[40, 0, 49.9, 50], [50, 50, 60, 100]], True),  # 0.1 m apart at that corner
])
def test_connectivity_hand_cases(rects, connected):
    space = _space(rects, [GOAL])
    start = np.array([10.0, 50.0])
    assert space.is_free(start)
    goal_labels = space.region_labels(*GOAL)
    assert goal_labels
    assert bool(space.start_labels(start) & goal_labels) == connected
    if not connected:  # every wall separates the two sides here
        sep = np.intersect1d(space.border(space.start_labels(start)), space.border(goal_labels))
        np.testing.assert_array_equal(sep, np.arange(len(rects)))


def test_goal_region_inside_an_inflated_obstacle():
    space = _space([[70, 40, 95, 60], [20, 20, 30, 30]], [GOAL])
    assert space.region_labels(*GOAL) == set()
    np.testing.assert_array_equal(space.covering(*GOAL), [0])
    half = _space([[70, 40, 85, 60]], [GOAL])  # the goal's east part stays free
    assert half.region_labels(*GOAL) == half.start_labels(np.array([10.0, 50.0]))


def test_enclosed_goal_and_a_start_inside_a_margin():
    """A goal walled in on four sides; a start inside one wall can leave it to either side."""
    walls = [[70, 35, 100, 40], [70, 60, 100, 65], [70, 35, 75, 65], [95, 35, 100, 65]]
    space = _space(walls, [GOAL])
    outside, inside = space.start_labels(np.array([10.0, 50.0])), space.region_labels(*GOAL)
    assert outside and inside and not outside & inside
    in_wall = space.start_labels(np.array([72.0, 50.0]))  # inside the west wall
    assert not space.is_free(np.array([72.0, 50.0]))
    assert in_wall == outside | inside


def test_label_grid_is_scipy_ndimage_label():
    """The numpy labelling that keeps scipy out of reading a mission gives the labels of
    ``scipy.ndimage.label`` (4-connectivity, numbered in C order of first cells) exactly:
    random masks of every density, a one-component snake (the longest chain of merges),
    a checkerboard (no two cells joined) and empty shapes."""
    from scipy import ndimage

    rng = np.random.default_rng(5)
    masks = [rng.random(tuple(rng.integers(1, 25, 2))) < rng.random() for _ in range(500)]
    snake = np.ones((41, 40), bool)
    snake[1::4, :-1] = False
    snake[3::4, 1:] = False
    masks += [snake, np.indices((9, 7)).sum(axis=0) % 2 == 0, np.zeros((3, 4), bool), np.ones((1, 1), bool),
              np.zeros((0, 5), bool)]
    for mask in masks:
        np.testing.assert_array_equal(label_grid(mask), ndimage.label(mask)[0])
    assert label_grid(snake).max() == 1 and label_grid(masks[-4]).max() == 32
