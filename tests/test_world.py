"""World geometry (004 Sec. III-D, Eq. 5): hand-derived points and segments."""

import numpy as np
import pytest

from uavsim.world import Region2D, cuboid_halfspaces, inside_polytopes, segments_hit_polytopes

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
