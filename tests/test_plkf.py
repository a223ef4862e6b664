"""The PLKF family of [Huang2021] (estimators/plkf.py); its study is tested in
tests/test_huang2021.py, its CRLB in tests/test_crlb.py.

Hand steps use one prediction ``x- = [10, 0, 1, 0]``, ``P- = I``, observer ``s = (-10, 0)``,
measured bearing 0.1 rad, sigma 0.05 rad: the predicted range is 20 m, so the PLKF's
``R = d^2 sigma^2 = 1`` and its innovation variance is 2.
"""

import numpy as np
import pytest

from uavsim.estimators import plkf

X, P, S, B, SIG = np.array([[10.0, 0, 1, 0]]), np.eye(4)[None], np.array([-10.0, 0]), 0.1, 0.05
sb, cb = np.sin(B), np.cos(B)


def test_plkf_step_by_hand():
    """Eq. (8), (11)-(13): H = [sin b, -cos b, 0, 0], z = -10 sin b, innovation -20 sin b."""
    x, p, ok = plkf.plkf_update(X, P, B, S, SIG)
    h = np.array([sb, -cb, 0, 0])
    assert ok.all()
    np.testing.assert_allclose(x[0], [10 - 10 * sb**2, 10 * sb * cb, 1, 0], atol=1e-12)
    np.testing.assert_allclose(p[0], np.eye(4) - np.outer(h, h) / 2, atol=1e-12)


def test_bc_plkf_step_by_hand():
    """Eq. (28) step 6: the PLKF update plus (sigma^2 / R) P M^T (M x - s), sigma^2 / R = 0.0025."""
    x_pl, p_pl, _ = plkf.plkf_update(X, P, B, S, SIG)
    x, p, ok = plkf.bc_plkf_update(X, P, B, S, SIG)
    np.testing.assert_allclose(x[0], x_pl[0] + 0.0025 * p_pl[0][:, :2] @ (x_pl[0, :2] - S), atol=1e-12)
    np.testing.assert_allclose(p, p_pl)
    assert x[0, 0] > x_pl[0, 0]  # compensation pushes the estimate out along the line of sight


def test_iv_plkf_step_by_hand():
    """IV step 7: G from the BC bearing; K = G^T / (R + H G^T) with P- = I; P = I - K H (symmetric part)."""
    x_bc, _, _ = plkf.bc_plkf_update(X, P, B, S, SIG)
    beta_bc = np.arctan2(x_bc[0, 1] - S[1], x_bc[0, 0] - S[0])
    g, h = np.array([np.sin(beta_bc), -np.cos(beta_bc), 0, 0]), np.array([sb, -cb, 0, 0])
    k = g / (1.0 + h @ g)
    x, p, ok = plkf.iv_plkf_update(X, P, B, S, SIG)
    np.testing.assert_allclose(x[0], X[0] + k * (-20 * sb), atol=1e-12)
    full = np.eye(4) - np.outer(k, h)
    np.testing.assert_allclose(p[0], (full + full.T) / 2, atol=1e-12)


def test_ub_plkf_step_by_hand():
    """Eq. (43)-(52) in the paper's divided form: beta^ = 0, m = -10, z_bar = sin b,
    H_bar = [0, 0.1, 0, 0], W = 0.0025 + 0.01, K = [0, 8, 0, 0]: y = 8 sin b, P_yy = 0.2."""
    x, p, ok = plkf.ub_plkf_update(X, P, B, S, SIG)
    np.testing.assert_allclose(x[0], [10, 8 * sb, 1, 0], atol=1e-12)
    np.testing.assert_allclose(p[0], np.diag([1, 0.2, 1, 1]), atol=1e-12)


@pytest.mark.parametrize("v_min, v_max, speed", [(0.5, 2.0, 1.0), (0.0, 0.5, 0.5), (2.0, 9.0, 2.0)])
def test_vc_plkf_step_by_hand(v_min, v_max, speed):
    """Eq. (80): inside the bounds the UB update; outside, the velocity scaled to the bound
    (Eq. 68), with the Joseph covariance of K*: K*_vx = (v/1 - 1) / eps, eps = -10 sin b,
    P_vx,vx = 1 + K*^2 (H P H^T = 1) + R K*^2 (R = m^2 sigma^2 = 0.25)."""
    x, p, ok = plkf.vc_plkf_update(X, P, B, S, SIG, v_min=v_min, v_max=v_max)
    x_ub, p_ub, _ = plkf.ub_plkf_update(X, P, B, S, SIG)
    np.testing.assert_allclose(x[0], [10, 8 * sb, speed, 0], atol=1e-12)
    k = (speed - 1.0) / (-10 * sb)
    np.testing.assert_allclose(p[0, 2, 2], 1 + 1.25 * k**2, atol=1e-12)
    if speed == 1.0:
        np.testing.assert_allclose(p, p_ub)
    np.testing.assert_allclose(p[0], p[0].T)


@pytest.mark.parametrize("kind", plkf.FILTERS)
def test_batched_step_equals_one_run_at_a_time(kind):
    rng = np.random.default_rng(3)
    x = rng.normal([500, 300, 2, 1], [30, 30, 1, 1], (7, 4))
    a = rng.normal(size=(7, 4, 4))
    p = a @ a.transpose(0, 2, 1) + 10 * np.eye(4)
    beta, s = rng.uniform(-np.pi, np.pi, 7), rng.normal(0, 100, (7, 2))
    kw = {"v_min": 1.0, "v_max": 2.0} if kind == "vc-plkf" else {}
    xb, pb, _ = plkf.UPDATES[kind](x, p, beta, s, 0.05, **kw)
    for r in range(7):
        x1, p1, _ = plkf.UPDATES[kind](x[r:r + 1], p[r:r + 1], beta[r], s[r], 0.05, **kw)
        np.testing.assert_allclose(xb[r], x1[0], rtol=1e-12, atol=1e-9)
        np.testing.assert_allclose(pb[r], p1[0], rtol=1e-12, atol=1e-9)


@pytest.mark.parametrize("kind", plkf.FILTERS)
def test_translation(kind):
    """PLKF, BC and IV are translation equivariant; UB and VC are not: ``m = u . s`` (Eq. 51)
    depends on where the origin is.  This is why the UB/VC results hinge on the scenario's
    coordinates (tests/test_huang2021.py)."""
    c = np.array([300.0, -200.0])
    shift = np.array([*c, 0, 0])
    kw = {"v_min": 0.0, "v_max": 0.5} if kind == "vc-plkf" else {}
    x1, _, _ = plkf.UPDATES[kind](X, P, B, S, SIG, **kw)
    x2, _, _ = plkf.UPDATES[kind](X + shift, P, B, S + c, SIG, **kw)
    moved = np.abs(x2 - shift - x1).max()
    if kind in ("ub-plkf", "vc-plkf"):
        assert moved > 0.1
    else:
        assert moved < 1e-9


def test_degenerate_update_is_reported_and_skipped():
    """UB with the observer at the origin (m = 0, so R = 0) and no position variance across
    the line of sight: zero innovation variance.  The run keeps its prediction, no NaN."""
    p = np.diag([1.0, 0.0, 1.0, 1.0])[None]
    kf = plkf.PseudoLinearKF("ub-plkf", np.eye(4), np.zeros((4, 4)), X, p)
    kf.step(B, np.zeros(2), SIG)
    np.testing.assert_array_equal(kf.x, X)
    assert kf.degenerate.tolist() == [1] and np.isfinite(kf.p).all()


def test_unknown_filter_is_refused():
    with pytest.raises(ValueError, match="choose from plkf"):
        plkf.PseudoLinearKF("ekf", np.eye(4), np.eye(4), X, P)


def test_ub_plkf_is_a_bearing_ekf_with_a_scaled_jacobian():
    """plkf.py docstring: the UB update equals an EKF
    update on the bearing with Jacobian alpha * grad beta, alpha = -d^ / (u^ . s), noise
    sigma^2 and innovation sin delta + (cos delta - 1) (n^ . s) / (u^ . s); checked on random
    geometries (alpha from -16 to 82, median |alpha| 2.5)."""
    rng = np.random.default_rng(11)
    r = 50
    x = rng.normal([800, -300, 5, -2], [400, 400, 3, 3], (r, 4))
    a = rng.normal(size=(r, 4, 4))
    p = a @ a.transpose(0, 2, 1) * 50 + np.eye(4)
    s, sigma = rng.normal(0, 500, (r, 2)), 0.03
    rel = x[:, :2] - s
    beta_hat = np.arctan2(rel[:, 1], rel[:, 0])
    beta = beta_hat + rng.normal(0, sigma, r)
    d_hat = np.linalg.norm(rel, axis=1)
    u = np.stack([np.cos(beta_hat), np.sin(beta_hat)], -1)
    n = np.stack([np.sin(beta_hat), -np.cos(beta_hat)], -1)
    alpha = -d_hat / np.einsum("ri,ri->r", u, s)
    h = np.zeros((r, 4))
    h[:, :2] = alpha[:, None] * np.stack([-np.sin(beta_hat), np.cos(beta_hat)], -1) / d_hat[:, None]
    delta = beta - beta_hat
    innov = np.sin(delta) + (np.cos(delta) - 1) * np.einsum("ri,ri->r", n, s) / np.einsum("ri,ri->r", u, s)
    ph = np.einsum("rij,rj->ri", p, h)
    k = ph / (np.einsum("ri,ri->r", h, ph) + sigma**2)[:, None]
    x_ekf = x + k * innov[:, None]
    p_ekf = p - k[:, :, None] * ph[:, None, :]
    x_ub, p_ub, ok = plkf.ub_plkf_update(x, p, beta, s, sigma)
    assert ok.all() and np.abs(alpha).max() > 5
    np.testing.assert_allclose(x_ub, x_ekf, rtol=1e-10, atol=1e-8)
    np.testing.assert_allclose(p_ub, (p_ekf + p_ekf.transpose(0, 2, 1)) / 2, rtol=1e-9, atol=1e-7)
