"""Target dynamics ([Papaioannou2023, Eq. (1)-(2)]) and open-loop moments (Eq. 6) against hand values."""

import numpy as np

from uavsim.targets import Dynamics, transition_matrices

PAPER_Q = np.diag([30, 30, 1e-10, 3, 3, 1e-10])


def test_matrices_paper_values():
    a, b = transition_matrices(1.0, 0.2, 1300.0)
    expect_a = np.zeros((6, 6))
    expect_a[:3, :3] = np.eye(3)
    expect_a[:3, 3:] = np.eye(3)
    expect_a[3:, 3:] = 0.8 * np.eye(3)
    np.testing.assert_allclose(a, expect_a, atol=1e-15)
    np.testing.assert_allclose(b, np.vstack([np.zeros((3, 3)), np.eye(3) / 1300]), atol=1e-15)


def test_one_step_by_hand():
    dyn = Dynamics(dt=0.5, friction=0.2, mass=1300.0, q=PAPER_Q)
    x = np.array([1.0, 2.0, 0.0, 3.0, 4.0, 0.0])
    u = np.array([2600.0, -5200.0, 0.0])
    # p' = p + dt v = (2.5, 4.0, 0); v' = 0.8 v + dt u / m = (2.4 + 1, 3.2 - 2, 0)
    np.testing.assert_allclose(dyn.step(x, u), [2.5, 4.0, 0.0, 3.4, 1.2, 0.0], atol=1e-13)
    # broadcasting over a batch of states gives the same row
    batch = dyn.step(np.tile(x, (5, 1)), u)
    np.testing.assert_allclose(batch, np.tile([2.5, 4.0, 0.0, 3.4, 1.2, 0.0], (5, 1)), atol=1e-13)


def test_moments_match_closed_form_eq6():
    dyn = Dynamics(dt=1.0, friction=0.2, mass=1300.0, q=PAPER_Q)
    rng = np.random.default_rng(0)
    mu = np.array([281.0, 925.0, 0.0, 1.0, -2.0, 0.0])
    sigma = np.diag([200, 200, 1e-10, 20, 20, 1e-10])
    u = np.column_stack([rng.uniform(-6000, 6000, (7, 2)), np.zeros(7)])
    means, covs = dyn.predict_moments(mu, sigma, u)
    a, b, q = dyn.a, dyn.b, dyn.q
    for tau in range(7):
        ap = np.linalg.matrix_power
        m = ap(a, tau + 1) @ mu + sum(ap(a, tau - k) @ b @ u[k] for k in range(tau + 1))
        s = ap(a, tau + 1) @ sigma @ ap(a.T, tau + 1)
        s = s + sum(ap(a, tau - k) @ q @ ap(a.T, tau - k) for k in range(tau + 1))
        np.testing.assert_allclose(means[tau], m, rtol=1e-12, atol=1e-9)
        np.testing.assert_allclose(covs[tau], s, rtol=1e-12, atol=1e-9)


def test_two_step_covariance_by_hand():
    """x-axis block with dt = 1, eps = 0.2: Sigma_0 = diag(200, 20), Q = diag(30, 3).

    Step 1: [[200 + 20 + 30, 0.8 * 20], [16, 0.64 * 20 + 3]] = [[250, 16], [16, 15.8]].
    Step 2: P11 = 250 + 2 * 16 + 15.8 + 30 = 327.8; P12 = 0.8 * (16 + 15.8) = 25.44;
            P22 = 0.64 * 15.8 + 3 = 13.112.
    """
    dyn = Dynamics(dt=1.0, friction=0.2, mass=1300.0, q=PAPER_Q)
    _, covs = dyn.predict_moments(np.zeros(6), np.diag([200, 200, 1e-10, 20, 20, 1e-10]), np.zeros((2, 3)))
    np.testing.assert_allclose(covs[0][np.ix_([0, 3], [0, 3])], [[250, 16], [16, 15.8]], atol=1e-12)
    np.testing.assert_allclose(covs[1][np.ix_([0, 3], [0, 3])], [[327.8, 25.44], [25.44, 13.112]], atol=1e-12)


def test_process_noise_statistics():
    """Sample covariance of nu ~ N(0, Q): each variance within 5 standard errors
    (se of a sample variance = var * sqrt(2 / n))."""
    n = 200_000
    dyn = Dynamics(dt=1.0, friction=0.2, mass=1300.0, q=PAPER_Q)
    nu = dyn.step(np.zeros((n, 6)), np.zeros(3), rng=np.random.default_rng(1))
    var = nu.var(axis=0)
    np.testing.assert_array_less(np.abs(var - np.diag(PAPER_Q)), 5 * np.diag(PAPER_Q) * np.sqrt(2 / n))
