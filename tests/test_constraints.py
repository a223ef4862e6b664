"""Equality constraints on an estimate ([Li2022] Sec. 3-4, Eq. 24-63, 81-83)."""

import numpy as np
import pytest
from scipy.optimize import minimize

from uavsim.estimators import constraints as C

LINE = np.array([[1.0, -1, 0, 0], [0, 0, 1, -1]])  # Eq. (72) with theta = pi/4


def test_point_on_a_line_by_hand():
    """Eq. (31) and (37) in the plane, line x = y (G = [1, -1], g = 0), point (2, 0):
    W = I gives (1, 1); W = P^-1 with P = diag(1, 3) gives (2, 0) - [1, -3] / 4 * 2 = (1.5, 1.5)."""
    x, g = np.array([[2.0, 0.0]]), np.array([[1.0, -1.0]])
    np.testing.assert_allclose(C.project_linear(x, g, [0.0])[0], [[1, 1]], atol=1e-15)
    np.testing.assert_allclose(C.project_linear(x, g, [0.0], np.diag([1.0, 3.0])[None])[0], [[1.5, 1.5]], atol=1e-15)


def test_paper_line_constraint_by_hand():
    """Eq. (72)-(73), W = I: [3, 1, 2, 0] -> positions averaged (2, 2), velocities (1, 1)."""
    x, ok = C.LinearProjection(LINE, np.zeros(2))(np.array([[3.0, 1, 2, 0]]), None)
    np.testing.assert_allclose(x, [[2, 2, 1, 1]], atol=1e-15)
    assert ok.all()


def test_w_identity_and_w_inverse_p_coincide_for_a_swap_symmetric_p():
    """With G of Eq. (72) the correction lies in the span of the antisymmetric vectors
    [1, -1, 0, 0], [0, 0, 1, -1]; a P that commutes with the x <-> y swap maps that span into
    itself, so P G^T (G P G^T)^-1 = G^T (G G^T)^-1: the published identical PL-MMSE-C rows
    (Table 5).  A P without the symmetry moves the result."""
    rng = np.random.default_rng(2)
    swap = np.eye(4)[[1, 0, 3, 2]]
    a = rng.normal(size=(20, 4, 4))
    p = a @ a.transpose(0, 2, 1) + np.eye(4)
    sym = (p + swap @ p @ swap) / 2
    x = rng.normal(size=(20, 4))
    x_i, _ = C.project_linear(x, LINE, np.zeros(2))
    np.testing.assert_allclose(C.project_linear(x, LINE, np.zeros(2), sym)[0], x_i, atol=1e-12)
    assert np.abs(C.project_linear(x, LINE, np.zeros(2), p)[0] - x_i).max() > 1e-2


def test_singular_projection_is_reported_and_skipped():
    """W = P^-1 with no position variance: G P G^T is singular; the run keeps x, ok False."""
    x = np.array([[3.0, 1, 2, 0], [3.0, 1, 2, 0]])
    p = np.stack([np.diag([0.0, 0, 1, 1]), np.eye(4)])
    out, ok = C.project_linear(x, LINE, np.zeros(2), p)
    assert ok.tolist() == [False, True]
    np.testing.assert_array_equal(out[0], x[0])


CENTRE, RADIUS = np.array([100.0, 0.0]), 100.0


def test_second_order_on_a_circle_is_radial_projection():
    """Eq. (43)-(63) with the circle (76)-(80) and W = I: exact for a quadric, so the nearest
    point of the circle, c + R (p - c) / |p - c|; the velocity is untouched (M = diag(1,1,0,0)
    is singular: the printed Cholesky of M would fail)."""
    rng = np.random.default_rng(4)
    x = rng.normal([200, 0, 0, 0.2], [3, 3, 0.1, 0.1], (50, 4))
    out, ok = C.second_order(x, C.circle(CENTRE, RADIUS))
    rel = x[:, :2] - CENTRE
    radial = CENTRE + RADIUS * rel / np.linalg.norm(rel, axis=1)[:, None]
    assert ok.all()
    np.testing.assert_allclose(out[:, :2], radial, atol=1e-12)
    np.testing.assert_array_equal(out[:, 2:], x[:, 2:])


def test_linear_approximation_on_a_circle_by_hand():
    """Eq. (42): the tangent-plane projection moves p along the radius to distance
    d - (d^2 - R^2) / (2 d) = (d^2 + R^2) / (2 d) from the centre, an error (d - R)^2 / (2 d)."""
    x = np.array([[100.0 + 110 * np.cos(0.3), 110 * np.sin(0.3), 1.0, 2.0]])
    out, ok = C.linear_approximation(x, C.circle(CENTRE, RADIUS))
    d = 110.0
    np.testing.assert_allclose(np.linalg.norm(out[0, :2] - CENTRE), (d**2 + RADIUS**2) / (2 * d), rtol=1e-14)
    np.testing.assert_allclose(np.arctan2(out[0, 1], out[0, 0] - 100), 0.3, rtol=1e-14)
    np.testing.assert_array_equal(out[0, 2:], x[0, 2:])


def _quadric(a, b=None, c=0.0):
    """``h(x) = x^T A x + b^T x`` (Hessian 2A), a quadric constraint on a 4-D state."""
    b = np.zeros(4) if b is None else b
    return C.ScalarConstraint(h=lambda x: np.einsum("ri,ij,rj->r", x, a, x) + x @ b, jac=lambda x: 2 * x @ a + b,
                              hess=lambda x: np.broadcast_to(2 * a, (len(x), 4, 4)), q=c)


def _slsqp(x0, w, fun, jac):
    """A generic constrained minimiser: argmin (y - x0)^T W (y - x0) s.t. fun(y) = 0."""
    res = minimize(lambda y: (y - x0) @ w @ (y - x0), x0, jac=lambda y: 2 * w @ (y - x0), method="SLSQP",
                   constraints=[{"type": "eq", "fun": fun, "jac": jac}], options={"ftol": 1e-15, "maxiter": 500})
    assert res.success
    return res.x


ELLIPSE = np.diag([1 / 4, 1 / 9, 0, 0])
HYPERBOLA = np.array([[0, 0.5, 0, 0], [0.5, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 0]])  # h = x y


@pytest.mark.parametrize("a, q", [(ELLIPSE, 1.0), (HYPERBOLA, 2.0)], ids=["ellipse", "hyperbola"])
@pytest.mark.parametrize("weighted", [False, True], ids=["W=I", "W=P^-1"])
def test_second_order_on_a_quadric_matches_a_generic_minimiser(a, q, weighted):
    """A non-circular quadric (an ellipse; a hyperbola, whose M is indefinite) projected with
    W = I and W = P^-1: Table 3's solution equals SLSQP's to 1e-6 and lies on the quadric."""
    rng = np.random.default_rng(7)
    x = rng.normal([1.5, 1.5, 0, 0], [0.3, 0.3, 1, 1], (5, 4))
    b = rng.normal(size=(5, 4, 4))
    p = b @ b.transpose(0, 2, 1) + np.eye(4) if weighted else np.broadcast_to(np.eye(4), (5, 4, 4))
    con = _quadric(a, c=q)
    out, ok = C.second_order(x, con, p if weighted else None)
    assert ok.all()
    np.testing.assert_allclose(con.h(out), q, atol=1e-12)
    for r in range(5):
        ref = _slsqp(x[r], np.linalg.inv(p[r]), lambda y: y @ a @ y - q, lambda y: 2 * a @ y)
        np.testing.assert_allclose(out[r], ref, atol=1e-6)


def test_quadric_lsq_general_form_matches_a_generic_minimiser():
    """Eq. (47) with a general H (5 x 4) and z: argmin |z - H x|^2 s.t. x^T M x + 2 m^T x + m0 = 0."""
    rng = np.random.default_rng(8)
    h = rng.normal(size=(3, 5, 4))
    z = rng.normal(size=(3, 5))
    a = rng.normal(size=(3, 4, 4))
    big_m = a @ a.transpose(0, 2, 1) + 0.1 * np.eye(4)
    m, m0 = rng.normal(size=(3, 4)), -np.full(3, 5.0)
    out, lam, ok = C.quadric_lsq(h, z, big_m, m, m0)
    assert ok.all()
    for hr, zr, mr, vr, m0r, xr, lr in zip(h, z, big_m, m, m0, out, lam):
        res = minimize(lambda y, hr=hr, zr=zr: np.sum((zr - hr @ y) ** 2), np.zeros(4), method="SLSQP",
                       jac=lambda y, hr=hr, zr=zr: -2 * hr.T @ (zr - hr @ y), options={"ftol": 1e-15, "maxiter": 500},
                       constraints=[{"type": "eq", "fun": lambda y, a=mr, b=vr, c=m0r: y @ a @ y + 2 * b @ y + c,
                                     "jac": lambda y, a=mr, b=vr: 2 * a @ y + 2 * b}])
        np.testing.assert_allclose(xr, res.x, atol=1e-6)
        # Eq. (49): the Lagrangian's gradient vanishes at (x~, lambda)
        np.testing.assert_allclose(-hr.T @ zr + lr * vr + (hr.T @ hr + lr * mr) @ xr, 0, atol=1e-9)


def test_printed_cholesky_and_svd_form_agrees_where_it_applies():
    """Eq. (52)-(57) as printed for a positive definite M: M = L^T L, H^T H = E^T E,
    L E^-1 = U Sigma V^T; the solver's d_i are the p_i^2 and (57) gives the solver's x~."""
    rng = np.random.default_rng(9)
    h, z = rng.normal(size=(4, 4)), rng.normal(size=4)
    a = rng.normal(size=(4, 4))
    big_m, m = a @ a.T + np.eye(4), rng.normal(size=4)
    out, lam, ok = C.quadric_lsq(h[None], z[None], big_m[None], m[None], np.array([-3.0]))
    ell = np.linalg.cholesky(big_m).T
    e = np.linalg.cholesky(h.T @ h).T
    _, sig, vt = np.linalg.svd(ell @ np.linalg.inv(e))
    d = np.linalg.eigvalsh(np.linalg.inv(e).T @ big_m @ np.linalg.inv(e))
    np.testing.assert_allclose(np.sort(sig**2), d, rtol=1e-12)
    v = vt.T
    e_lam = v.T @ np.linalg.inv(e).T @ (h.T @ z - lam[0] * m)  # Eq. (55)
    x57 = np.linalg.inv(e) @ v @ (e_lam / (1 + lam[0] * sig**2))  # Eq. (57)
    np.testing.assert_allclose(out[0], x57, atol=1e-12)


def test_second_order_on_a_non_quadric_solves_its_taylor_quadric():
    """h(x) = exp(x1 / 2) + x2^2 = 3 (general h): S is the projection onto the second-order
    Taylor quadric about x^ (Eq. 43-46); it ends nearer the true constraint than L does."""
    con = C.ScalarConstraint(
        h=lambda x: np.exp(x[:, 0] / 2) + x[:, 1] ** 2,
        jac=lambda x: np.stack([np.exp(x[:, 0] / 2) / 2, 2 * x[:, 1], 0 * x[:, 0], 0 * x[:, 0]], -1),
        hess=lambda x: np.einsum("r,ij->rij", np.exp(x[:, 0] / 2) / 4, np.diag([1.0, 0, 0, 0]))
        + np.diag([0, 2.0, 0, 0]), q=3.0)
    x = np.array([[1.0, 1.5, 0.3, -0.2]])
    out, ok = C.second_order(x, con)
    hs, j, h0 = con.hess(x)[0], con.jac(x)[0], con.h(x)[0]

    def taylor(y):
        dy = y - x[0]
        return h0 - con.q + j @ dy + dy @ hs @ dy / 2

    ref = _slsqp(x[0], np.eye(4), taylor, lambda y: j + hs @ (y - x[0]))
    np.testing.assert_allclose(out[0], ref, atol=1e-6)
    lin, _ = C.linear_approximation(x, con)
    assert abs(con.h(out)[0] - 3) < 0.1 * abs(con.h(lin)[0] - 3)


def test_no_root_is_reported_and_the_estimate_kept():
    """|x|^2 = -1 has no point: f(lambda) stays positive on the bracket; ok False, x unchanged."""
    x = np.array([[1.0, 2, 3, 4]])
    out, ok = C.second_order(x, _quadric(np.eye(4), c=-1.0))
    assert not ok[0]
    np.testing.assert_array_equal(out, x)


def test_tangent_velocity_by_hand():
    """Eq. (81)-(83) at (200, 0) about the centre (100, 0): theta = 0, mu = (0, 1), so
    v = (1, 2) -> (0, 2).  The printed angle about the origin, at (200, 100):
    theta = atan(1/2), mu = (-1, 2)/sqrt(5), v . mu = 3/sqrt(5), v~ = (3/5)(-1, 2)."""
    out, ok = C.tangent_velocity(np.array([[200.0, 0, 1, 2]]), CENTRE)
    np.testing.assert_allclose(out[0], [200, 0, 0, 2], atol=1e-15)
    out, ok = C.tangent_velocity(np.array([[200.0, 100, 1, 2]]), CENTRE, about="origin")
    np.testing.assert_allclose(out[0], [200, 100, -0.6, 1.2], atol=1e-15)


@pytest.mark.parametrize("make", [lambda: C.LinearProjection(LINE, np.zeros(2), "W"),
                                  lambda: C.NonlinearProjection(C.circle(CENTRE, RADIUS), "third-order"),
                                  lambda: C.TangentVelocity((100.0, 0.0), "north")])
def test_unknown_setting_is_refused(make):
    with pytest.raises(ValueError, match="must be one of"):
        make()
