"""World geometry ([Papaioannou2023, Sec. III-D, Eq. (5)]): hand-derived points and segments."""

import numpy as np
import pytest

from uavsim.world import (
    Polygons,
    Region2D,
    World,
    convex_ccw,
    cuboid_halfspaces,
    ground_footprints,
    inside_polytopes,
    prism_halfspaces,
    segments_hit_polytopes,
)
from uavsim.world.space import free_space

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
    kept, ground = ground_footprints(Polygons.boxes(lo[:, :2], hi[:, :2]), lo[:, 2], hi[:, 2], 9.0)
    np.testing.assert_array_equal(kept, [0, 1, 4])
    np.testing.assert_array_equal(ground.lo, [[-9, -9]] * 3)
    np.testing.assert_array_equal(ground.hi, [[19, 29]] * 3)


def _space(rects, regions=()):
    r = np.array(rects, dtype=float).reshape(-1, 4)
    return free_space(Polygons.boxes(r[:, :2], r[:, 2:]), AREA_LO, AREA_HI)


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


DIAMOND = np.array([[10.0, 0.0], [0.0, 10.0], [-10.0, 0.0], [0.0, -10.0]])  # a square turned 45 degrees
PENTAGON = np.array([[0.0, 0.0], [4.0, 0.0], [5.0, 3.0], [2.0, 5.0], [-1.0, 3.0]])


def test_polygons_by_hand():
    """Padded arrays: a diamond and a pentagon (widths 4 and 5).  The diamond's edge from
    (10, 0) to (0, 10) has normal (1, 1)/sqrt 2 and offset 10/sqrt 2; pushed out by m it
    becomes the diamond of half-diagonal 10 + m sqrt 2 (area 2 (10 + m sqrt 2)^2)."""
    p = Polygons.from_list([DIAMOND, PENTAGON])
    assert p.width == 5 and p.sides.tolist() == [4, 5] and p.valid[0].tolist() == [True] * 4 + [False]
    np.testing.assert_allclose(p.normals[0, 0], np.array([1.0, 1.0]) / np.sqrt(2), atol=1e-15)
    np.testing.assert_allclose(p.offsets[0, :4], 10 / np.sqrt(2))
    # the pentagon by the shoelace formula: (0 + 12 + 19 + 11 + 0) / 2
    np.testing.assert_allclose(p.area, [200.0, 21.0], rtol=0, atol=1e-12)
    big = p.inflated(2.0)
    np.testing.assert_allclose(big.vertices[0, :4], DIAMOND * (10 + 2 * np.sqrt(2)) / 10, atol=1e-12)
    np.testing.assert_allclose(big.area[0], 2 * (10 + 2 * np.sqrt(2)) ** 2, rtol=1e-12)
    edge = 10 + 2 * np.sqrt(2)
    assert big.contains(np.array([[edge - 1e-9, 0.0], [edge + 1e-9, 0.0]]))[:, 0].tolist() == [True, False]
    # the inflated pentagon's corners lie on both neighbouring edges pushed out by 2
    v, a, b = big.vertices[1, :5], p.normals[1, :5], p.offsets[1, :5]
    np.testing.assert_allclose(np.einsum("fd,fd->f", v, a), b + 2.0, atol=1e-12)
    np.testing.assert_allclose(np.einsum("fd,fd->f", v, np.roll(a, 1, axis=0)), np.roll(b, 1) + 2.0, atol=1e-12)
    np.testing.assert_array_equal(p.neighbours()[1, 0], [4, 1])
    np.testing.assert_array_equal(p.neighbours()[0, 4], [4, 4])  # a padded face points at itself


def test_convexity_and_orientation_checks():
    assert convex_ccw(DIAMOND) == "" and convex_ccw(PENTAGON) == ""
    assert "clockwise" in convex_ccw(DIAMOND[::-1])
    assert "vertex 1" in convex_ccw(np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [1.0, 1.0]]))  # straight corner
    assert "at least 3" in convex_ccw(DIAMOND[:2]) and "repeats" in convex_ccw(np.vstack([DIAMOND, DIAMOND[-1:]]))
    star = np.array([[np.cos(a), np.sin(a)] for a in np.arange(5) * 4 * np.pi / 5])  # a pentagram: twice round
    assert convex_ccw(star) == "winds round more than once"


def test_a_box_prism_is_the_cuboid():
    """The half-spaces of a box footprint's prism are the cuboid's six (in another order),
    and a world of prisms tests points and segments like the cuboid world."""
    lo, hi = np.array([1.0, 2.0]), np.array([3.0, 5.0])
    a, b = prism_halfspaces(Polygons.boxes(lo, hi), np.array([0.0]), np.array([4.0]))
    c, d = cuboid_halfspaces(LO, HI)
    assert sorted(map(tuple, np.c_[a[0], b[0]])) == sorted(map(tuple, np.c_[c[0], d[0]]))
    diamond = World.of_prisms("d", np.full(3, -50.0), np.full(3, 50.0), Polygons.from_list([DIAMOND]),
                              np.array([[0.0, 20.0]]), ["D"], ())
    pts = np.array([[5.0, 4.9, 1.0], [5.0, 5.1, 1.0], [5.0, 4.9, 20.5], [-4.0, -6.0, 0.0]])
    assert diamond.in_obstacle(pts).tolist() == [True, False, False, True]
    assert diamond.segment_blocked(np.array([[-20.0, 11.0, 1.0], [-20.0, 9.0, 1.0]]),
                                   np.array([[20.0, 11.0, 1.0], [20.0, 9.0, 1.0]])).tolist() == [False, True]
    np.testing.assert_array_equal(diamond.obstacle_lo, [[-10.0, -10.0, 0.0]])


def _random_prisms(seed: int) -> World:
    """12 random convex prisms and boxes in a 200 m square, some raised off the ground."""
    rng = np.random.default_rng(seed)
    polys = []
    for c in rng.uniform(20, 180, size=(8, 2)):
        angles = np.sort(rng.uniform(0, 2 * np.pi, size=rng.integers(3, 9)))
        polys.append(c + rng.uniform(5, 20) * np.column_stack([np.cos(angles), np.sin(angles)]))
    lo = rng.uniform(0, 150, size=(4, 2))
    footprints = Polygons.concat(Polygons.from_list(polys), Polygons.boxes(lo, lo + rng.uniform(5, 40, size=(4, 2))))
    z = np.column_stack([np.where(rng.random(12) < 0.8, 0.0, 5.0), rng.uniform(8, 40, size=12)])
    return World.of_prisms("w", np.zeros(3), np.full(3, 200.0), footprints, z, [f"o{i}" for i in range(12)], ())


def test_in_obstacle_tests_the_near_obstacles_as_it_would_every_one():
    """``in_obstacle`` tests only the obstacles whose boxes meet the points' box; its verdict
    is every obstacle's half-space test's, for a cloud of ground points and for points on
    the obstacles' faces and corners (closed obstacles) and just beyond them."""
    world = _random_prisms(3)
    rng = np.random.default_rng(4)
    cloud = np.c_[rng.normal(100.0, 20.0, size=(5000, 2)), np.zeros(5000)]
    corners = world.footprints.vertices[world.footprints.valid]
    faces = np.c_[corners, np.zeros(len(corners))]
    beyond = faces + np.r_[1e-9, 1e-9, 0.0] * np.sign(faces - [100.0, 100.0, 0.0])
    for pts in (cloud, cloud[:40], faces, beyond, world.obstacle_hi, world.obstacle_lo + [0.0, 0.0, -1e-9]):
        every = inside_polytopes(pts, world.normals, world.offsets).any(axis=-1)
        np.testing.assert_array_equal(world.in_obstacle(pts), every)
    assert world.in_obstacle(faces).any() and not world.in_obstacle(np.empty((0, 3))).size



def test_fans_under_the_moves_see_behind_the_point():
    """A point under the grid of moves near its north edge, and a 50 m block just north-east
    of it: the move at (105, 120) is hidden (its segment crosses the block 2-3 m from the
    point, under 27 m up), though, seen from the point, the block lies wholly outside the
    directions to the grid's hull corners (the point is inside the hull: the fan has no
    wedge to part them).  fans_blocked gives segment_blocked's verdicts."""
    w = World("block", np.zeros(3), np.full(3, 200.0), np.array([[101.0, 119.0, 0.0]]),
              np.array([[106.0, 124.0, 50.0]]), ("block",), ())
    grid = np.stack(np.meshgrid(np.arange(-20, 21, 5.0), np.arange(-20, 21, 5.0)), -1).reshape(-1, 2)
    moves = np.column_stack([100.0 + grid, np.full(len(grid), 40.0)])
    point = np.array([[100.0, 117.0, 0.0]])
    want = w.segment_blocked(moves[:, None], point[None])[:, 0]
    assert want[np.all(moves[:, :2] == [105.0, 120.0], axis=1)].all() and want.sum() < 4
    np.testing.assert_array_equal(w.fans_blocked(moves, point)[:, 0], want)


def test_segment_blocked_equals_the_exact_clip_of_every_face():
    """The two-phase test (boxes, circles over the segment's part at obstacle heights, then the
    footprint's sides) gives the verdict of Cyrus-Beck against all faces of every obstacle, for
    20 000 random segments among 12 random prisms and cuboids (touching included: segments that
    end on a face, lie in a roof's plane or stand vertical)."""
    w = _random_prisms(11)
    rng = np.random.default_rng(11)
    p0 = rng.uniform(0, 200, size=(20000, 3)) * [1, 1, 0.3]
    p1 = rng.uniform(0, 200, size=(20000, 3)) * [1, 1, 0.3]
    p1[:500, :2] = p0[:500, :2]  # vertical
    p0[500:1000, 2] = p1[500:1000, 2] = w.obstacle_hi[rng.integers(12, size=500), 2]  # in a roof's plane
    p1[1000:1500] = w.obstacle_hi[rng.integers(12, size=500)]  # ending on a corner
    want = segments_hit_polytopes(p0, p1, w.normals, w.offsets).any(axis=-1)
    np.testing.assert_array_equal(w.segment_blocked(p0, p1), want)
    assert 0.2 < want.mean() < 0.8


@pytest.mark.parametrize("seed", range(6))
def test_fans_give_the_verdict_of_every_segment(seed):
    """World.fans_blocked (culled by separating axes, a point hidden from the observers'
    whole hull by one obstacle) equals segment_blocked, and Cyrus-Beck against every face,
    for every (observer, point) pair: a UAV's grid of moves over ground points (some under
    the grid, some inside obstacles), observers at mixed heights, and degenerate hulls
    (one observer, a line of them)."""
    rng = np.random.default_rng(seed)
    w = _random_prisms(seed)
    centre = rng.uniform(40, 160, size=2)
    grid = np.stack(np.meshgrid(np.arange(-20, 21, 5.0), np.arange(-20, 21, 5.0)), -1).reshape(-1, 2)
    fans = {"grid": np.column_stack([centre + grid, np.full(len(grid), 40.0)]),
            "heights": np.column_stack([centre + grid, rng.uniform(0, 60, len(grid))]),
            "one": np.array([[*centre, 40.0]]),
            "line": np.column_stack([centre[0] + np.arange(-20, 21, 5.0), np.full(9, centre[1]), np.full(9, 30.0)])}
    points = np.column_stack([rng.uniform(0, 200, size=(400, 2)), np.where(rng.random(400) < 0.8, 0.0, 12.0)])
    points[:40, :2] = centre + rng.uniform(-20, 20, size=(40, 2))  # under the observers
    for name, observers in fans.items():
        want = w.segment_blocked(observers[:, None], points[None])
        np.testing.assert_array_equal(w.fans_blocked(observers, points), want, err_msg=name)
        exact = segments_hit_polytopes(observers[:, None], points[None], w.normals, w.offsets).any(axis=-1)
        np.testing.assert_array_equal(want, exact, err_msg=name)
        assert 0.05 < want.mean() < 0.95, name
