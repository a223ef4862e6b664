"""The recursive CRLB of [Huang2021] and its velocity-constrained form (bounds/crlb.py),
on the scenarios of its study (studies/huang2021_scenarios.py)."""

import numpy as np

from uavsim.bounds.crlb import bearing_gradients, constrained, crlb
from uavsim.studies.huang2021_scenarios import scenario


def test_crlb_recursion_equals_the_joint_fisher_information():
    """Appendix B's recursion against inverting the block-tridiagonal FIM of the whole
    track ``x_1..x_K`` (prior, K-1 transitions, K bearings): the last block must agree."""
    sc = scenario("huang2021-scenario2")
    k, n = 6, 4
    truth, obs, sig = sc.truth[:k], sc.observer[:k], sc.sigma_true[:k]
    h = bearing_gradients(truth, obs)
    qi = np.linalg.inv(sc.q)
    big = np.zeros((k * n, k * n))
    for i in range(k):
        blk = slice(i * n, (i + 1) * n)
        big[blk, blk] += np.outer(h[i], h[i]) / sig[i] ** 2
        if i == 0:
            big[blk, blk] += np.linalg.inv(sc.p0)
        if i + 1 < k:
            nxt = slice((i + 1) * n, (i + 2) * n)
            big[blk, blk] += sc.f.T @ qi @ sc.f
            big[nxt, nxt] += qi
            big[blk, nxt] -= sc.f.T @ qi
            big[nxt, blk] -= qi @ sc.f
    direct = np.linalg.inv(big)[-n:, -n:]
    np.testing.assert_allclose(crlb(truth, obs, sig, sc.f, sc.q, sc.p0)[-1], direct, rtol=1e-9)


def test_a_deterministic_truth_has_the_information_of_its_start_carried_along():
    """Q = 0: x_k = F^k x_0 exactly, so the information on x_k is that on x_0 (the prior
    plus every bearing's, each through F^j) carried by F^-k: the recursion against that
    sum, and the random-truth bound (with the filters' Q) above it (it cannot know less)."""
    sc = scenario("huang2021-scenario2")
    k = 40
    truth, obs, sig = sc.truth[:k], sc.observer[:k], sc.sigma_true[:k]
    h = bearing_gradients(truth, obs)
    info0 = np.linalg.inv(sc.p0) + sum(np.linalg.matrix_power(sc.f, j).T @ np.outer(h[j], h[j])
                                       @ np.linalg.matrix_power(sc.f, j) / sig[j] ** 2 for j in range(k))
    fk = np.linalg.matrix_power(sc.f, k - 1)
    direct = fk @ np.linalg.inv(info0) @ fk.T
    bound = crlb(truth, obs, sig, sc.f, np.zeros((4, 4)), sc.p0)
    np.testing.assert_allclose(bound[-1], direct, rtol=1e-8)
    noisy = crlb(truth, obs, sig, sc.f, sc.q, sc.p0)
    assert np.all(np.linalg.eigvalsh(noisy[-1] - bound[-1]) > -1e-9 * np.abs(noisy[-1]).max())


def test_bearing_gradient_by_finite_differences():
    x, s = np.array([1000.0, 1000, 10, -10]), np.array([500.0, 500])

    def beta(state):
        return np.arctan2(state[1] - s[1], state[0] - s[0])

    num = [(beta(x + e) - beta(x - e)) / 2e-3 for e in 1e-3 * np.eye(4)]
    np.testing.assert_allclose(bearing_gradients(x[None], s[None])[0], num, atol=1e-10)


def test_constrained_bound_has_no_variance_along_the_speed_gradient():
    """Eq. (B6): ``U J_C^-1 = 0`` and ``J^-1 - J_C^-1`` is positive semi-definite."""
    sc = scenario("huang2021-scenario2")
    b = crlb(sc.truth, sc.observer, sc.sigma_true, sc.f, sc.q, sc.p0)
    bc = constrained(b, sc.truth)
    u = np.zeros((len(b), 4))
    u[:, 2:] = 2 * sc.truth[:, 2:]
    assert np.abs(np.einsum("ki,kij->kj", u, bc)).max() < 1e-9 * np.abs(b).max()
    assert np.linalg.eigvalsh(b - bc).min() > -1e-9 * np.abs(b).max()
