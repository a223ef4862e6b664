"""Shortest routes among inflated footprints: hand-derived lengths, agreement with the
exact free-space connectivity, and the segment distances against dense sampling."""

import numpy as np
import pytest

from uavsim.world import Polygons
from uavsim.world.routes import (
    GoalField,
    distinct_routes,
    faces_along,
    path_lengths,
    segment_distance,
    segment_polygon_distance,
    shortest_route,
)
from uavsim.world.space import free_space

AREA = (np.array([-50.0, -50.0]), np.array([150.0, 50.0]))


def test_shortest_path_round_one_rectangle_by_hand():
    """Start (0, 0), goal (100, 0), rectangle [40, 60] x [-10, 10]: over a long side,
    2 sqrt(40^2 + 10^2) + 20 = 102.4621... m, bending at two corners."""
    lo, hi = np.array([[40.0, -10.0]]), np.array([[60.0, 10.0]])
    r = shortest_route([0, 0], [100, 0], Polygons.boxes(lo, hi), *AREA)
    assert r.length == pytest.approx(2 * np.hypot(40, 10) + 20, abs=1e-12)
    assert r.points.shape == (4, 2) and np.array_equal(r.points[[0, -1]], [[0, 0], [100, 0]])
    assert set(map(tuple, r.points[1:3])) in ({(40, 10), (60, 10)}, {(40, -10), (60, -10)})


def test_two_routes_round_one_rectangle_by_hand():
    """Rectangle [40, 60] x [-10, 20], goal (100, 30): over the top, bending at (40, 20)
    only, sqrt(40^2 + 20^2) + sqrt(60^2 + 10^2) = 105.55 m (the obstacle on the route's
    right, face +y); underneath, sqrt(40^2 + 10^2) + 20 + sqrt(40^2 + 40^2) = 117.80 m (on
    its left, face -y); round one obstacle no third class exists."""
    lo, hi = np.array([[40.0, -10.0]]), np.array([[60.0, 20.0]])
    routes = distinct_routes([0, 0], [100, 30], Polygons.boxes(lo, hi), *AREA, k=3)
    assert [r.length for r in routes] == pytest.approx(
        [np.hypot(40, 20) + np.hypot(60, 10), np.hypot(40, 10) + 20 + np.hypot(40, 40)], abs=1e-9)
    top, bottom = routes
    np.testing.assert_array_equal(top.points, [[0, 0], [40, 20], [100, 30]])
    np.testing.assert_array_equal(bottom.points, [[0, 0], [40, -10], [60, -10], [100, 30]])
    assert [(p.obstacle, p.face, p.turn, p.touching) for p in top.passes] == [(0, 2, -1, True)]
    assert [(p.obstacle, p.face, p.turn, p.touching) for p in bottom.passes] == [(0, 0, 1, True)]
    assert top.sides == {0: 2} and bottom.sides == {0: 0}  # faces -y, +x, +y, -x
    half = top.sample(3)[1]  # half the length along the route: on its second leg
    np.testing.assert_allclose(np.linalg.norm(half - [40, 20]) + np.hypot(40, 20), top.length / 2, rtol=1e-12)


def test_route_through_a_corridor_and_its_alternative():
    """A wall x in [40, 60] with a 10 m gap at y in [-5, 5]: straight through the corridor
    (100 m, touching nothing), then over the upper wall's end, 2 sqrt(40^2 + 40^2) + 20 m;
    the lower wall meets the area's edge, so there is no third class."""
    lo, hi = np.array([[40.0, -50.0], [40.0, 5.0]]), np.array([[60.0, -5.0], [60.0, 40.0]])
    routes = distinct_routes([0, 0], [100, 0], Polygons.boxes(lo, hi), *AREA, k=3)
    assert len(routes) == 2
    assert routes[0].length == pytest.approx(100.0, abs=1e-12) and len(routes[0].points) == 2
    assert [(p.obstacle, p.face, p.turn, p.touching) for p in routes[0].passes] == [(0, 2, -1, False), (1, 0, 1, False)]
    assert routes[1].length == pytest.approx(2 * np.hypot(40, 40) + 20, abs=1e-9)
    assert routes[1].sides[1] == 2 and {p.obstacle: p.turn for p in routes[1].passes}[1] == -1


def test_no_route_where_the_free_space_is_split():
    lo, hi = np.array([[40.0, -50.0], [40.0, 0.0]]), np.array([[60.0, 0.0], [60.0, 50.0]])  # touching walls
    assert shortest_route([0, 0], [100, 0], Polygons.boxes(lo, hi), *AREA) is None
    assert distinct_routes([0, 0], [100, 0], Polygons.boxes(lo, hi), *AREA) == []
    assert np.isinf(path_lengths([[0, 0]], [100, 0], Polygons.boxes(lo, hi), *AREA)).all()


def test_start_inside_a_rectangle_leaves_it_straight():
    lo, hi = np.array([[-10.0, -10.0]]), np.array([[10.0, 10.0]])
    r = shortest_route([5, 0], [100, 0], Polygons.boxes(lo, hi), *AREA)
    assert r.length == pytest.approx(95.0) and len(r.points) == 2


def random_rects(rng, n):
    """Rectangles on a 10 m lattice, so touching edges and corners are common."""
    a = rng.integers(-5, 15, (n, 2)) * 10.0
    size = rng.integers(1, 5, (n, 2)) * 10.0
    a[:, 1] = rng.integers(-5, 5, n) * 10.0
    return a, a + size


def test_routes_agree_with_exact_connectivity():
    """A route exists exactly when start and goal share a free component of the compressed
    grid, on 150 random lattice layouts (touching rectangles and walls on the edge)."""
    rng = np.random.default_rng(3)
    both = 0
    for _ in range(150):
        lo, hi = random_rects(rng, int(rng.integers(3, 9)))
        start, goal = np.array([-45.0, 3.0]), np.array([145.0, -3.0])
        space = free_space(Polygons.boxes(lo, hi), *AREA)
        if not (space.is_free(start) and space.is_free(goal)):
            continue
        connected = bool(space.start_labels(start) & space.start_labels(goal))
        route = shortest_route(start, goal, Polygons.boxes(lo, hi), *AREA)
        assert (route is not None) == connected
        if route is not None:
            mid = 0.5 * (route.points[1:] + route.points[:-1])  # no segment midpoint inside a rectangle
            assert not np.any(np.all((mid[:, None] > lo) & (mid[:, None] < hi), axis=-1))
            both += 1
    assert 20 < both < 130  # both outcomes were exercised


def test_goal_field_equals_the_shortest_route():
    rng = np.random.default_rng(5)
    lo, hi = random_rects(rng, 6)
    goal = np.array([145.0, 0.0])
    starts = rng.uniform(AREA[0], AREA[1], (40, 2))
    field = GoalField(goal, Polygons.boxes(lo, hi), *AREA)
    got = field.lengths(starts)
    for s, length in zip(starts, got):
        r = shortest_route(s, goal, Polygons.boxes(lo, hi), *AREA)
        assert (r is None and np.isinf(length)) or r.length == pytest.approx(length, rel=1e-12)


def point_to_segment(p, a, b):
    """Distance from points p to segment ab by projection (an independent form)."""
    t = np.clip(np.sum((p - a) * (b - a), -1) / np.sum((b - a) ** 2, -1), 0, 1)
    return np.linalg.norm(a + t[..., None] * (b - a) - p, axis=-1)


def test_distances_against_dense_sampling():
    """Segment-segment and segment-box distances: never above the distance from any
    sampled point of the first segment, and within one sampling step of the closest."""
    rng = np.random.default_rng(11)
    a0, a1, b0, b1 = rng.uniform(-1, 1, (4, 500, 2))
    s = np.linspace(0, 1, 2001)[:, None, None]
    pa = a0 + s * (a1 - a0)  # (2001, 500, 2)
    sampled = point_to_segment(pa, b0, b1).min(axis=0)
    d = segment_distance(a0, a1, b0, b1)
    step = np.linalg.norm(a1 - a0, axis=1) / 2000
    assert np.all(d <= sampled + 1e-12) and np.all(sampled - d <= step)
    assert np.mean(d == 0) > 0.1 and np.mean(d > 0) > 0.1
    lo, hi = np.array([[-0.2, -0.3]]), np.array([[0.3, 0.1]])
    box = segment_polygon_distance(a0, a1, Polygons.boxes(lo, hi))[:, 0]
    sampled_box = np.linalg.norm(np.maximum(0, np.maximum(lo - pa, pa - hi)), axis=-1).min(axis=0)
    assert np.all(box <= sampled_box + 1e-12) and np.all(sampled_box - box <= step)
    assert np.mean(box == 0) > 0.1 and np.mean(box > 0) > 0.1


def test_faces_along_by_hand():
    lo, hi = np.array([[0.0, 0.0], [10.0, 10.0]]), np.array([[1.0, 1.0], [20.0, 12.0]])
    pts = np.array([[5.0, 0.5], [-3.0, 0.5], [0.5, 4.0], [0.5, -2.0]])
    faces = faces_along(pts, Polygons.boxes(lo, hi))  # a box's faces: -y, +x, +y, -x
    np.testing.assert_array_equal(faces[:, 0], [1, 3, 2, 0])
    np.testing.assert_array_equal(faces[:, 1], [0, 3, 3, 0])


def test_routes_round_a_diamond_by_hand():
    """A square turned 45 degrees, half-diagonal 10, between (-30, 0) and (30, 0): the two
    shortest routes bend at its top and bottom corners, each 2 sqrt(30^2 + 10^2) long,
    and pass it on opposite sides; no route touches the inside."""
    diamond = Polygons.from_list([[[10.0, 0.0], [0.0, 10.0], [-10.0, 0.0], [0.0, -10.0]]])
    routes = distinct_routes([-30, 0], [30, 0], diamond, *AREA, k=3)
    assert len(routes) == 2
    assert [r.length for r in routes] == pytest.approx([2 * np.hypot(30, 10)] * 2, abs=1e-12)
    assert {tuple(r.points[1]) for r in routes} == {(0.0, 10.0), (0.0, -10.0)}
    assert {r.passes[0].turn for r in routes} == {1, -1} and all(r.passes[0].touching for r in routes)
    mid = 0.5 * (routes[0].points[1:] + routes[0].points[:-1])
    assert not diamond.contains(mid, tol=-1e-9).any()


def test_turned_squares_touching_at_a_corner_close_the_passage():
    """Two diamonds meeting at (0, 0): closed (a pinch of zero width), as for touching
    boxes; moved 0.1 m apart, the corridor opens, for routes and free space alike."""
    def two(gap):
        d = np.array([[10.0, 0.0], [0.0, 10.0], [-10.0, 0.0], [0.0, -10.0]])
        return Polygons.from_list([d + [0.0, -10.0 - gap / 2], d + [0.0, 10.0 + gap / 2]])

    for gap, open_ in ((0.0, False), (0.1, True)):
        walls = two(gap)
        route = shortest_route([-30, 0], [30, 0], walls, np.array([-40.0, -20.0]), np.array([40.0, 20.0]))
        space = free_space(walls, np.array([-40.0, -20.0]), np.array([40.0, 20.0]))
        assert (route is not None) == open_
        assert bool(space.start_labels(np.array([-30.0, 0.0])) & space.start_labels(np.array([30.0, 0.0]))) == open_


def test_one_visibility_graph_answers_every_query_as_a_fresh_one():
    """The corner edges are found once and kept (one set with the tangent rule, one
    without, for a terminal inside a polygon): each query's graph equals the one built
    from scratch, every node pair tested, whatever was asked before it."""
    from uavsim.world.routes import Visibility, _sees, _tangent

    rng = np.random.default_rng(3)
    polys = Polygons.boxes(*random_rects(rng, 12))
    vis = Visibility(polys, *AREA)
    queries = [([-45.0, -45.0], [145.0, 45.0]), (polys.centres[0], [145.0, -45.0]), ([-45.0, 45.0], [140.0, 0.0])]
    for start, goal in queries + queries[::-1]:
        terminals = np.array([start, goal], dtype=float)
        nodes, vectors, restricted = vis.nodes(terminals)
        i, j = np.triu_indices(len(nodes), 1)
        d = nodes[j] - nodes[i]
        keep = _tangent(d, vectors[i], restricted[i]) & _tangent(d, vectors[j], restricted[j])
        i, j = i[keep], j[keep]
        ok = _sees(vis.scene, nodes[i], nodes[j])
        got_nodes, pairs, length = vis.graph(terminals)
        np.testing.assert_array_equal(got_nodes, nodes)
        np.testing.assert_array_equal(pairs, np.column_stack([i[ok], j[ok]]))
        np.testing.assert_array_equal(length, np.linalg.norm(nodes[j[ok]] - nodes[i[ok]], axis=1))
    assert set(vis._edges) == {True, False}


def test_a_start_at_an_obstacles_centre_has_finite_routes():
    """A start at the centre of the box it is inside: the first route leaves it straight,
    and the barrier that asks for another way round is a real ray, not NaN."""
    lo, hi = np.array([[-10.0, -10.0]]), np.array([[10.0, 10.0]])
    with np.errstate(all="raise"):
        routes = distinct_routes([0, 0], [100, 0], Polygons.boxes(lo, hi), *AREA, k=3)
    assert routes[0].length == pytest.approx(100.0)
    assert all(np.isfinite(r.points).all() and np.isfinite(r.length) for r in routes)
