"""PL-MMSE under Gaussian-mixture noise and its baselines ([Li2022] Sec. 2, Table 1).

Hand steps use [Huang2021]'s test geometry (``tests/test_plkf.py``): prediction ``x- = [10, 0, 1, 0]``,
``P- = I``, observer ``s = (-10, 0)``, measured bearing 0.1 rad, a one-component mixture
with sigma 0.05 rad.  The predicted bearing is 0 and the predicted range 20 m.
"""


import numpy as np
import pytest

from uavsim.estimators import plkf
from uavsim.estimators.constraints import LinearProjection
from uavsim.estimators.plmmse import FILTERS, UPDATES, GaussianMixture, PseudoLinearGM, cv_model, pl_mmse_gain

X, P, S, B = np.array([[10.0, 0, 1, 0]]), np.eye(4)[None], np.array([-10.0, 0]), 0.1
ONE = GaussianMixture([1.0], [0.05**2])


def test_mixture_moments_by_hand():
    """Eq. (5)-(6), (15): E cos e = sum w exp(-s^2/2), E sin^2 e = sum w (1 - exp(-2 s^2))/2, Q = sum w Q_j."""
    gm = GaussianMixture([0.4, 0.6], [0.015, 0.019])
    assert gm.mean_cos() == pytest.approx(0.4 * np.exp(-0.0075) + 0.6 * np.exp(-0.0095), rel=1e-15)
    assert gm.mean_sin2() == pytest.approx(0.2 * (1 - np.exp(-0.03)) + 0.3 * (1 - np.exp(-0.038)), rel=1e-14)
    assert gm.cov[0, 0] == pytest.approx(0.0174)
    q = GaussianMixture([0.4, 0.6], [np.diag([0, 0, 0.15, 0.15]), np.diag([0, 0, 0.23, 0.23])])
    np.testing.assert_allclose(q.cov, np.diag([0, 0, 0.198, 0.198]), atol=1e-15)


def test_mixture_samples_have_the_mixture_moments():
    """200k draws: the sample variance, E cos e and E sin^2 e within 4 standard errors of the
    closed forms, and a scaled mixture gives rho times the same draws (to rounding)."""
    gm = GaussianMixture([0.4, 0.6], [0.1**2, 0.5**2])
    e = gm.sample(np.random.default_rng(5), 200_000)[:, 0]
    for sample, exact in ((e**2, gm.cov[0, 0]), (np.cos(e), gm.mean_cos()), (np.sin(e) ** 2, gm.mean_sin2())):
        assert abs(sample.mean() - exact) < 4 * sample.std() / np.sqrt(len(e))
    np.testing.assert_allclose(gm.scaled(3.0).sample(np.random.default_rng(5), 10),
                               3.0 * gm.sample(np.random.default_rng(5), 10), rtol=1e-14)
    # a 4-D mixture with a singular component (the process noise's zero position block)
    q = GaussianMixture([0.4, 0.6], [np.diag([0, 0, 1.0, 1.0]), np.array([[2, 1, 0, 0], [1, 2, 0, 0],
                                                                          [0, 0, 3, 0], [0, 0, 0, 3.0]])])
    w = q.sample(np.random.default_rng(6), 200_000)
    outer = w[:, :, None] * w[:, None, :]
    assert (np.abs(outer.mean(0) - q.cov) < 4 * outer.std(0) / np.sqrt(len(w)) + 1e-12).all()


@pytest.mark.parametrize("weights, covs", [([0.5, 0.6], [1.0, 2.0]), ([1.5, -0.5], [1.0, 2.0]), ([1.0], [-1.0]),
                                           ([0.5, 0.5], [1.0])])
def test_bad_mixture_is_refused(weights, covs):
    with pytest.raises(ValueError):
        GaussianMixture(weights, covs)


def test_process_model_by_hand():
    """Eq. (11)-(12), (14): D Q D^T with Q = diag(0, 0, q, q) is q [[T^4/4, T^3/2], [T^3/2, T^2]] per axis."""
    f, q = cv_model(0.1, GaussianMixture([1.0], [np.diag([0, 0, 2.0, 2.0])]))
    np.testing.assert_allclose(f, [[1, 0, 0.1, 0], [0, 1, 0, 0.1], [0, 0, 1, 0], [0, 0, 0, 1]])
    np.testing.assert_allclose(q[[0, 0, 2], [0, 2, 2]], [2 * 0.1**4 / 4, 2 * 0.1**3 / 2, 2 * 0.1**2], rtol=1e-14)


def test_pl_mmse_step_by_hand():
    """Table 1 steps 4-6 (re-derived): H1 = [0, -1, 0, 0] (predicted bearing 0), K1 = c1 [0, -1, 0, 0],
    K2 = H P H^T (= 1) - 2 s2 + 400 s2, innovation z - H x- = -20 sin b, P_yy = 1 - c1^2 / K2."""
    c1, s2 = np.exp(-0.05**2 / 2), (1 - np.exp(-2 * 0.05**2)) / 2
    k2 = 1 - 2 * s2 + 400 * s2
    x, p, ok = UPDATES["pl-mmse"](X, P, B, S, ONE)
    assert ok.all()
    np.testing.assert_allclose(x[0], [10, c1 * 20 * np.sin(B) / k2, 1, 0], atol=1e-12)
    np.testing.assert_allclose(p[0], np.diag([1, 1 - c1**2 / k2, 1, 1]), atol=1e-12)


def test_pl_mmse_gain_against_monte_carlo():
    """K1 = E[x~ nu] and E[K2] = E[nu^2] (the re-derived Table 1 step 4), by 200k Monte-Carlo
    draws of the state from N(x-, P-) and of a heavy mixture (sigma 0.1 and 0.5 rad, so c1 = 0.93:
    a K1 without c1 would be 7% off, 14 standard errors).  The bearing noise enters in antithetic
    pairs (e, -e), which keeps the expectation (the mixture is symmetric) and removes most of
    the variance.  Tolerance: 4 standard errors; the linearisation of the true bearing in the
    derivation costs O(tr P / r^2) ~ 4e-4 relative, well inside it."""
    rng = np.random.default_rng(1)
    noise = GaussianMixture([0.4, 0.6], [0.1**2, 0.5**2])
    xp, s = np.array([100.0, 50, 1, -1]), np.array([-20.0, 10])
    cov = np.array([[4, 1, 0.5, 0], [1, 2, 0, 0.3], [0.5, 0, 1, 0.1], [0, 0.3, 0.1, 1.0]])
    n = 200_000
    x = xp + rng.standard_normal((n, 4)) @ np.linalg.cholesky(cov).T
    phi, e = np.arctan2(x[:, 1] - s[1], x[:, 0] - s[0]), noise.sample(rng, n)[:, 0]
    xs, ps = np.broadcast_to(xp, (n, 4)), np.broadcast_to(cov, (n, 4, 4))
    (k1, k2a, za, ha, _), (_, k2b, zb, hb, _) = (pl_mmse_gain(xs, ps, phi + sign * e, s, noise) for sign in (1, -1))
    nu_a, nu_b = za - ha @ xp, zb - hb @ xp
    cross = (x - xp) * ((nu_a + nu_b) / 2)[:, None]
    se = cross.std(axis=0, ddof=1) / np.sqrt(n)
    np.testing.assert_array_less(np.abs(cross.mean(axis=0) - k1[0]), 4 * se)
    assert np.abs(k1[0]).max() / se.max() > 100  # the comparison resolves K1 to 1%
    diff = (nu_a**2 + nu_b**2) / 2 - (k2a + k2b) / 2
    assert abs(diff.mean()) < 4 * diff.std(ddof=1) / np.sqrt(n)
    assert diff.std(ddof=1) / np.sqrt(n) < 0.01 * k2a.mean()


@pytest.mark.parametrize("kind, update", [("plkf", plkf.plkf_update), ("bc-plkf", plkf.bc_plkf_update),
                                          ("ivkf", plkf.iv_plkf_update)])
def test_baselines_are_huang2021_filters_with_sigma2_replaced_by_e_sin2(kind, update):
    """The baselines under GM noise: [Huang2021]'s updates with sigma^2 = E sin^2 e (plmmse docstring)."""
    gm = GaussianMixture([0.4, 0.6], [0.1**2, 0.5**2])
    x, p, _ = UPDATES[kind](X, P, B, S, gm)
    x2, p2, _ = update(X, P, B, S, np.sqrt(gm.mean_sin2()))
    np.testing.assert_array_equal(x, x2)
    np.testing.assert_array_equal(p, p2)


def test_degenerate_pl_mmse_update_keeps_the_prediction():
    """A position spread larger than the range (P = 1e6 I against r = 20 m): K2 falls below
    c1^2 H1 P H1^T, the updated P would be indefinite; the run keeps its prediction."""
    p = np.diag([1e6, 1e6, 1.0, 1.0])[None]
    x, p_new, ok = UPDATES["pl-mmse"](X, p, 0.0, S, ONE)
    assert not ok[0]
    np.testing.assert_array_equal(x, X)
    np.testing.assert_array_equal(p_new, p)


@pytest.mark.parametrize("kind", FILTERS)
def test_batched_step_equals_one_run_at_a_time(kind):
    rng = np.random.default_rng(3)
    x = rng.normal([100, 50, 2, 1], [10, 10, 1, 1], (6, 4))
    a = rng.normal(size=(6, 4, 4))
    p = a @ a.transpose(0, 2, 1) + np.eye(4)
    beta, s = rng.uniform(-np.pi, np.pi, 6), rng.normal(0, 30, (6, 2))
    gm = GaussianMixture([0.4, 0.6], [0.01, 0.04])
    xb, pb, _ = UPDATES[kind](x, p, beta, s, gm)
    for r in range(6):
        x1, p1, _ = UPDATES[kind](x[r:r + 1], p[r:r + 1], beta[r], s[r], gm)
        np.testing.assert_allclose(xb[r], x1[0], rtol=1e-12, atol=1e-10)
        np.testing.assert_allclose(pb[r], p1[0], rtol=1e-12, atol=1e-10)


def _track(feedback):
    """Five steps of PL-MMSE with the line constraint x = y, vx = vy (W = P^-1)."""
    rng = np.random.default_rng(0)
    f, q = cv_model(0.1, GaussianMixture([1.0], [np.diag([0, 0, 0.2, 0.2])]))
    con = LinearProjection(np.array([[1.0, -1, 0, 0], [0, 0, 1, -1]]), np.zeros(2), "P")
    kf = PseudoLinearGM("pl-mmse", f, q, ONE, rng.normal([5, 5, 1, 1], 0.5, (4, 4)), np.eye(4), con, feedback)
    out = []
    for k in range(5):
        kf.step(np.pi / 4 + rng.normal(0, 0.05, 4), np.array([0.0, -k]))
        out.append((kf.x.copy(), kf.p.copy(), kf.estimate.copy()))
    return out, con


def test_wrapper_without_feedback_projects_its_own_estimate():
    """Table 2 step 5 read as an output: the filter state is unconstrained, its output is the
    projection of that state (with the filter's P); with feedback the state itself obeys x = y."""
    plain, con = _track(False)
    for x, p, est in plain:
        np.testing.assert_array_equal(est, con(x, p)[0])
        assert np.abs(x[:, 0] - x[:, 1]).max() > 1e-3
    fed, _ = _track(True)
    np.testing.assert_allclose(fed[-1][0][:, 0], fed[-1][0][:, 1], atol=1e-12)


def test_unknown_filter_is_refused():
    with pytest.raises(ValueError, match="choose from pl-mmse"):
        PseudoLinearGM("ekf", np.eye(4), np.eye(4), ONE, X, P)

