"""Particle filter ([Papaioannou2023, Sec. V-A]): Eq. (10) against its brute-force form, the filter
against an exact Kalman filter, resampling and moments by hand."""

import math

import numpy as np
import pytest

from uavsim.belief.gaussian import GaussianBelief
from uavsim.belief.particle import (
    ParticleBelief,
    ParticleFilter,
    by_label,
    cluster_weights,
    clusters,
    halves,
    join_clusters,
    label_mass,
    reference_clusters,
    restricted_draws,
    systematic_indices,
    weighted_moments,
    within_spread,
)
from uavsim.sensing import BearingModel, log_likelihood, uniform_loglik, wrap_angle
from uavsim.targets import Dynamics


def eq10_brute_force(phis, expected, lam, pd, sigma):
    """Eq. (10) exactly as printed: factorials, Poisson pmfs, products over the set."""
    n = len(phis)
    p_clutter = 1.0 / (2.0 * math.pi)

    def psi(k):
        return math.exp(-lam) * lam**k / math.factorial(k) if k >= 0 else 0.0

    def c(phi):
        r = float(wrap_angle(phi - expected))
        return math.exp(-0.5 * (r / sigma) ** 2) / (sigma * math.sqrt(2.0 * math.pi))

    miss = (1 - pd) * math.factorial(n) * psi(n) * p_clutter**n
    det = 0.0
    if n >= 1:
        det = math.factorial(n - 1) * psi(n - 1) * pd * sum(c(phi) * p_clutter ** (n - 1) for phi in phis)
    return miss + det


CASES = [  # (lambda, p_D, set size)
    (1.0, 0.95, 0), (1.0, 0.95, 1), (1.0, 0.95, 3), (8.0, 0.95, 6), (0.0, 0.95, 0), (0.0, 0.95, 1),
    (0.0, 1.0, 1), (2.5, 1.0, 2), (2.5, 0.0, 2), (0.3, 0.5, 4),
]


@pytest.mark.parametrize("lam, pd, n", CASES)
def test_closed_form_matches_eq10_with_factorials(lam, pd, n):
    rng = np.random.default_rng(n + int(10 * lam))
    sigma = math.radians(1.0)
    expected = rng.uniform(-math.pi, math.pi, 40)  # 40 particles' noise-free bearings
    phis = wrap_angle(np.r_[expected[0] + 0.01, rng.uniform(-math.pi, math.pi, max(n - 1, 0))][:n])
    k = max(n, 1)
    bearings = np.zeros((1, k))
    bearings[0, :n] = phis
    valid = np.arange(k)[None, :] < n
    got = np.exp(log_likelihood(bearings, valid, expected[None, :], BearingModel(sigma, pd, lam)))[0]
    want = np.array([eq10_brute_force(phis, e, lam, pd, sigma) for e in expected])
    np.testing.assert_allclose(got, want, rtol=1e-11, atol=1e-300)


def test_impossible_sets_are_minus_infinity_not_nan():
    """Two measurements without clutter, or a miss when p_D = 1: likelihood zero."""
    s = BearingModel(math.radians(1), 1.0, 0.0)
    bearings, valid = np.zeros((2, 2)), np.array([[True, True], [False, False]])
    out = log_likelihood(bearings, valid, np.zeros((2, 5)), s)
    assert np.all(out == -np.inf) and not np.isnan(out).any()


def test_log_domain_survives_large_sets():
    """400 false alarms: (1/2pi)^400 ~ 1e-320 underflows a product; the log does not."""
    n = 400
    s = BearingModel(math.radians(1), 0.95, 400.0)
    bearings = np.linspace(-3, 3, n)[None, :]
    out = log_likelihood(bearings, np.ones((1, n), bool), np.array([[0.0, 1.0]]), s)
    assert np.all(np.isfinite(out))
    # value check with lgamma instead of factorials: miss term dominates for a far particle
    lam = 400.0
    log_miss = math.log(0.05) + n * math.log(lam / (2 * math.pi)) - lam
    assert out[0, 1] >= log_miss - 1e-9


def test_systematic_resampling_counts_by_hand():
    """Systematic resampling picks particle i floor(N w_i) or ceil(N w_i) times."""
    rng = np.random.default_rng(0)
    w = rng.dirichlet(np.ones(50), size=3)
    idx = systematic_indices(rng, w)
    counts = np.array([np.bincount(row, minlength=50) for row in idx])
    assert np.all(counts >= np.floor(50 * w) - 1e-9) and np.all(counts <= np.ceil(50 * w) + 1e-9)


def test_systematic_resampling_to_fewer_particles_by_hand():
    """k draws from N weights pick particle i floor(k w_i) or ceil(k w_i) times."""
    rng = np.random.default_rng(4)
    w = rng.dirichlet(np.ones(50), size=3)
    idx = systematic_indices(rng, w, 20)
    counts = np.array([np.bincount(row, minlength=50) for row in idx])
    assert idx.shape == (3, 20)
    assert np.all(counts >= np.floor(20 * w) - 1e-9) and np.all(counts <= np.ceil(20 * w) + 1e-9)


@pytest.mark.parametrize("lam, pd, n", [(1.0, 0.95, 0), (1.0, 0.95, 1), (1.0, 0.95, 3), (0.0, 0.9, 1),
                                        (0.0, 1.0, 1), (2.5, 0.0, 2)])
def test_uniform_loglik_is_eq10_averaged_over_the_circle(lam, pd, n):
    """``g_u`` equals Eq. (10) averaged over 200 000 bearings spread evenly on the circle
    (sigma = 5 deg, so the truncated Gaussian tails are ~1e-300 of its mass)."""
    rng = np.random.default_rng(n)
    k = max(n, 1)
    bearings = np.zeros((1, k))
    bearings[0, :n] = rng.uniform(-math.pi, math.pi, n)
    valid = np.arange(k)[None, :] < n
    s = BearingModel(math.radians(5.0), pd, lam)
    grid = np.linspace(-math.pi, math.pi, 200_000, endpoint=False)[None, :]
    want = np.log(np.exp(log_likelihood(bearings, valid, grid, s)).mean())
    np.testing.assert_allclose(uniform_loglik(valid, s), [want], rtol=1e-9)


def _belief_on(target: np.ndarray, spread: float, nats: float, n: int = 400, seed: int = 0) -> ParticleBelief:
    """One target's belief of n particles around ``target (2,)`` (std ``spread`` m)."""
    mean = np.r_[target, 0.0, 0.0, 0.0, 0.0][None]
    cov = np.diag([spread**2, spread**2, 1.0, 1.0, 1.0, 1.0])[None]
    return ParticleBelief(np.random.default_rng(seed), mean, cov, n, 0.5, 0.0, ("T1",), nats)


def test_track_loss_is_declared_from_the_bearings_not_by_chance():
    """Paper sensor (1 deg, p_D 0.95, Lambda 1), target 400 m north of the sensor.  A cloud
    on the target survives 200 scans without a loss; a cloud 100 m east of it (14 deg
    off, 14 sigma) is declared lost after 3-5 scans: a detection adds log(1 + 19 n)
    (3.0-3.7 nats) against a threshold of 10."""
    from uavsim.sensing import observe

    s = BearingModel(math.radians(1.0), 0.95, 1.0)
    truth, observer = np.array([[0.0, 400.0, 0.0]]), np.zeros(3)
    rng = np.random.default_rng(7)
    on, off = _belief_on(truth[0, :2], 5.0, 10.0), _belief_on(truth[0, :2] + [100.0, 0.0], 5.0, 10.0)
    lost_at = None
    for k in range(200):
        scan = observe(rng, s, truth, observer)
        on.update([scan], observer[None], s)
        assert not on.lost[0], f"a cloud on its target declared lost at scan {k}"
        off.update([scan], observer[None], s)
        if lost_at is None and off.lost[0]:
            lost_at = k + 1
    assert lost_at is not None and 3 <= lost_at <= 5


def test_loss_detection_off_never_declares():
    s = BearingModel(math.radians(1.0), 0.95, 1.0)
    from uavsim.sensing import observe

    b, rng = _belief_on(np.array([100.0, 400.0]), 5.0, 0.0), np.random.default_rng(1)
    for _ in range(20):
        b.update([observe(rng, s, np.array([[0.0, 400.0, 0.0]]), np.zeros(3))], np.zeros((1, 3)), s)
    assert not b.lost.any() and b.cusum[0] == 0.0


def test_a_cloud_collapsed_to_a_point_is_declared_lost():
    """A cloud whose particles are all one point (a resample copied one particle) claims to
    know the position exactly and the bearings cannot widen it: after one scan of a target
    the cloud sits on, it is declared lost and the event names it; a cloud 0.01 m wide
    (above the 1 mm limit) is not.  Without loss detection it is reported only."""
    from uavsim.sensing import observe

    s, truth, observer = BearingModel(math.radians(1.0), 0.95, 1.0), np.array([[0.0, 400.0, 0.0]]), np.zeros(3)
    for spread, nats, lost in ((0.0, 10.0, True), (0.01, 10.0, False), (0.0, 0.0, False)):
        b = _belief_on(truth[0, :2], 5.0, nats)
        b.pf.particles[0] = truth[0, 0] + np.r_[0.0, 400.0, 0.0, 0.0, 0.0, 0.0]
        b.pf.particles[0, :, 0] += spread * np.random.default_rng(3).standard_normal(400)
        events = b.update([observe(np.random.default_rng(4), s, truth, observer)], observer[None], s)
        assert b.lost[0] == lost
        assert any("collapsed to a point" in e for e in events) == (spread == 0.0)


def test_reseed_keeps_the_cloud_share_and_weighs_all_alike():
    """Re-seeding 100 of 400 particles: the 300 kept are a systematic resample of the
    weighted cloud (each particle floor(300 w) or ceil(300 w) times), the 100 fresh ones
    follow, every weight is 1/400 and the loss evidence restarts."""
    b = _belief_on(np.array([0.0, 0.0]), 5.0, 10.0)
    w = np.random.default_rng(2).dirichlet(np.ones(400))
    b.pf.logw = np.log(w)[None]
    b.cusum[0] = 12.0
    old = b.pf.particles.copy()
    fresh = np.full((1, 100, 6), 77.0)
    b.reseed(np.array([0]), fresh)
    assert np.all(b.pf.particles[0, 300:] == 77.0) and b.cusum[0] == 0.0
    np.testing.assert_allclose(b.pf.weights, 1 / 400)
    picked = (b.pf.particles[0, :300, None, :] == old[0, None]).all(-1).argmax(axis=1)
    counts = np.bincount(picked, minlength=400)
    assert np.all(counts >= np.floor(300 * w) - 1e-9) and np.all(counts <= np.ceil(300 * w) + 1e-9)


def test_moments_eq11_match_numpy():
    rng = np.random.default_rng(1)
    p = rng.normal(size=(2, 300, 6))
    w = rng.dirichlet(np.ones(300), size=2)
    mean, cov = weighted_moments(p, w)
    for m in range(2):
        np.testing.assert_allclose(mean[m], np.average(p[m], axis=0, weights=w[m]), atol=1e-13)
        np.testing.assert_allclose(cov[m], np.cov(p[m].T, aweights=w[m], bias=True), atol=1e-13)


def test_degenerate_update_is_skipped_and_reported():
    rng = np.random.default_rng(2)
    pf = ParticleFilter.from_priors(rng, np.zeros((2, 6)), np.tile(np.eye(6), (2, 1, 1)), 100)
    before = pf.logw.copy()
    loglik = np.zeros((2, 100))
    loglik[1] = -np.inf
    bad, _ = pf.update(loglik)
    assert bad.tolist() == [False, True]
    np.testing.assert_array_equal(pf.logw[1], before[1])
    assert np.all(np.isfinite(pf.logw))


def kalman(mu, p, a, b, q, u, h, r, zs):
    for z, uk in zip(zs, u):
        mu, p = a @ mu + b @ uk, a @ p @ a.T + q
        s = h @ p @ h.T + r
        k = p @ h.T @ np.linalg.inv(s)
        mu, p = mu + k @ (z - h @ mu), (np.eye(6) - k @ h) @ p
    return mu, p


@pytest.mark.parametrize("correlated", [False, True])
@pytest.mark.parametrize("n", [5000, 997])  # 997 is prime: the wide view is one row wide
def test_predict_is_eq9a_with_the_generators_next_normals(correlated, n):
    """Eq. (9a) ``x <- A x + B u + L z`` with z the generator's next (M, N, 6) normals,
    for a diagonal Q (scaled in place) and a correlated one (the white-noise-acceleration
    Q, a full Cholesky factor: matrix product).  Only rounding may differ."""
    dt = 1.0
    q = np.diag([30.0, 30.0, 1e-10, 3.0, 3.0, 1e-10])
    if correlated:
        block = np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]]) * 4.0
        q = np.kron(block, np.eye(3)) + 1e-10 * np.eye(6)
    dyn = Dynamics(dt, 0.2, 1300.0, q)
    assert np.any(np.tril(dyn.q_chol, -1)) == correlated  # the two paths of predict
    rng = np.random.default_rng(11)
    x0 = rng.normal(size=(2, n, 6)) * 50.0
    u = rng.uniform(-3000, 3000, (2, 3))
    pf = ParticleFilter(x0.copy(), np.full((2, n), -np.log(n)))
    pf.predict(np.random.default_rng(12), dyn.a, dyn.b, dyn.q_chol, u)
    z = np.random.default_rng(12).standard_normal((2, n, 6))
    want = x0 @ dyn.a.T + (u @ dyn.b.T)[:, None, :] + z @ dyn.q_chol.T
    np.testing.assert_allclose(pf.particles, want, rtol=1e-12, atol=1e-9)
    # plan_clusters = 2: the masked particles move by the other force, the rest as before
    mask, other = rng.random((2, n)) < 0.3, rng.uniform(-3000, 3000, (2, 3))
    pf = ParticleFilter(x0.copy(), np.full((2, n), -np.log(n)))
    pf.predict(np.random.default_rng(12), dyn.a, dyn.b, dyn.q_chol, u, (mask, other))
    want[mask] += ((other - u) @ dyn.b.T)[np.nonzero(mask)[0]]
    np.testing.assert_allclose(pf.particles, want, rtol=1e-12, atol=1e-9)


def test_halves_finds_two_separated_clouds_whatever_their_weights():
    """Two clouds 10 standard deviations apart in velocity only (same positions: a plan
    depends on velocity too), one of them with 10% of the weight, in shuffled order: the
    split is exactly the two clouds.  One unimodal cloud splits into two halves of about
    equal weight (the principal-axis hyperplane through the mean; 2-means keeps it)."""
    rng = np.random.default_rng(5)
    n = 4000
    a = rng.normal(size=(n // 2, 6)) * [20, 20, 0, 1, 1, 0]
    b = a[::-1] + [0, 0, 0, 10, 0, 0]
    x = np.concatenate([a, b])
    order = rng.permutation(n)
    w = np.r_[np.full(n // 2, 0.9), np.full(n // 2, 0.1)] / (n // 2)
    side = halves(x[order][None], w[order][None])[0]
    truth = (order >= n // 2)
    assert np.array_equal(side, truth) or np.array_equal(side, ~truth)
    one = halves(a[None], np.full((1, n // 2), 2.0 / n))[0]
    assert abs(one.mean() - 0.5) < 0.05


def test_clusters_find_separated_clouds_and_are_deterministic():
    """Four clouds apart in position or velocity (a plan depends on both), unequal weights,
    shuffled: k-means with k = 4 labels exactly the four clouds (a permutation of them), the
    same on a second call.  With k = 6 no cloud is split across another's cluster: every
    cluster lies inside one cloud."""
    rng = np.random.default_rng(8)
    n = 800
    shifts = np.array([[0, 0, 0, 0, 0, 0], [200, 0, 0, 0, 0, 0], [0, 0, 0, 12, 0, 0], [0, 200, 0, 0, -12, 0]])
    x = np.concatenate([rng.normal(size=(n, 6)) * [10, 10, 0, 1, 1, 0] + s for s in shifts])
    cloud = np.repeat(np.arange(4), n)
    order = rng.permutation(4 * n)
    w = np.repeat([0.4, 0.3, 0.2, 0.1], n)[order] / n
    label = clusters(x[order][None], w[None], 4)[0]
    pairs = set(zip(cloud[order].tolist(), label.tolist()))
    assert len(pairs) == 4 and len({c for c, _ in pairs}) == 4 and len({k for _, k in pairs}) == 4
    np.testing.assert_array_equal(label, clusters(x[order][None], w[None], 4)[0])
    six = clusters(x[order][None], w[None], 6)[0]
    assert all(len(set(cloud[order][six == k].tolist())) == 1 for k in np.unique(six))


def test_particles_join_the_reference_cluster_nearest_in_its_scale():
    """By hand: reference means at (x, vx) = (0, 4) and (6, 0); a particle at (2, 1) is
    nearer the first in equal scales (4 + 9 = 13 against 16 + 1 = 17) and the second when x
    counts a tenth (0.04 + 9 against 0.16 + 1); a cluster without particles is never
    joined.  The four separated clouds of the test above, drawn twice: the second draw joins
    the first's clusters cloud by cloud, and the reference cloud itself joins its own
    k-means labels (its cells)."""
    means = np.zeros((1, 2, 6))
    means[0, 0, 3], means[0, 1, 0] = 4.0, 6.0
    p = np.zeros((1, 1, 6))
    p[0, 0, [0, 3]] = 2.0, 1.0
    live = np.ones((1, 2), bool)
    assert join_clusters(p, means, np.ones((1, 4)), live)[0, 0] == 0
    assert join_clusters(p, means, np.array([[10.0, 1.0, 1.0, 1.0]]), live)[0, 0] == 1
    assert join_clusters(p, means, np.ones((1, 4)), np.array([[False, True]]))[0, 0] == 1
    rng = np.random.default_rng(8)
    n = 500
    shifts = np.array([[0, 0, 0, 0, 0, 0], [200, 0, 0, 0, 0, 0], [0, 0, 0, 12, 0, 0], [0, 200, 0, 0, -12, 0]])
    ref, other = (np.concatenate([rng.normal(size=(n, 6)) * [10, 10, 0, 1, 1, 0] + s for s in shifts])[None]
                  for _ in range(2))
    means, covs, scale, live = reference_clusters(ref, 4)
    assert live.all() and covs.shape == (1, 4, 6, 6)
    own = clusters(ref, np.full((1, 4 * n), 1.0 / (4 * n)), 4)
    np.testing.assert_array_equal(join_clusters(ref, means, scale, live), own)
    joined = join_clusters(other, means, scale, live)[0].reshape(4, n)
    np.testing.assert_array_equal(joined, own[0].reshape(4, n)[:, :1].repeat(n, axis=1))


def test_label_mass_is_each_clusters_weight():
    """By hand: weights 0.1 0.2 0.3 0.4 labelled 0 1 0 2 (k = 4) hold 0.4, 0.2, 0.4 and 0
    (an empty cluster); a second cloud labelled all 3 holds 1 there.  The same as the mass of
    :func:`cluster_weights`, row by row."""
    w = np.array([[0.1, 0.2, 0.3, 0.4], [0.25, 0.25, 0.25, 0.25]])
    lab = np.array([[0, 1, 0, 2], [3, 3, 3, 3]])
    np.testing.assert_allclose(label_mass(w, lab, 4), [[0.4, 0.2, 0.4, 0.0], [0.0, 0.0, 0.0, 1.0]], atol=1e-15)
    np.testing.assert_allclose(label_mass(w, lab, 4), cluster_weights(w, lab, 4)[1], atol=1e-15)


def test_by_label_gives_each_particle_its_clusters_rows():
    """By hand: two targets' three clusters of (2, 2) rows; labels 2 0 2 and 1 1 0 pick
    those clusters' rows for each particle, the same as ``np.take_along_axis``."""
    per = np.arange(2 * 3 * 2 * 2, dtype=float).reshape(2, 3, 2, 2)
    lab = np.array([[2, 0, 2], [1, 1, 0]])
    got = by_label(per, lab)
    np.testing.assert_array_equal(got, [[per[0, 2], per[0, 0], per[0, 2]], [per[1, 1], per[1, 1], per[1, 0]]])
    np.testing.assert_array_equal(got, np.take_along_axis(per, lab[..., None, None], axis=1))
    np.testing.assert_array_equal(by_label(per[..., 0, 0], lab), [[8.0, 0.0, 8.0], [16.0, 16.0, 12.0]])


def test_committed_prediction_is_the_cluster_force_plus_the_gain_on_the_offset():
    """``motion = "commit"``: after :meth:`ParticleBelief.commit` each particle's offset is
    its [x, y, vx, vy] less its cluster's weighted mean, and the prediction is Eq. (9a)
    with force ``u_c + K_c offset`` (by hand, with the generator's next normals); resampling
    carries a particle's cluster and offset with it; a re-seeded particle joins the
    cluster whose plan's state now is nearest, with no offset, whether or not any particle
    kept is of that cluster."""
    rng = np.random.default_rng(2)
    mean = np.zeros((1, 6))
    cov = np.diag([400.0, 400.0, 1e-10, 4.0, 4.0, 1e-10])[None]
    b = ParticleBelief(np.random.default_rng(3), mean, cov, 600, 0.5, 0.0, ("T1",))
    means, _, mass = b.commit(3)
    lab, x = b.pf.label[0], b.pf.particles[0]
    np.testing.assert_allclose(mass[0].sum(), 1.0)
    for c in range(3):
        np.testing.assert_allclose(means[0, c], x[lab == c].mean(axis=0), atol=1e-9)
        np.testing.assert_allclose(b.pf.offset[0, lab == c], (x[lab == c] - means[0, c])[:, [0, 1, 3, 4]], atol=1e-9)
    forces = rng.uniform(-3000, 3000, (1, 3, 3))
    gains = rng.normal(size=(1, 3, 3, 4)) * 50.0
    dyn = Dynamics()
    b.rng = np.random.default_rng(9)
    b.predict_committed(dyn, forces, gains)
    u = forces[0, lab] + np.einsum("nij,nj->ni", gains[0, lab], b.pf.offset[0])
    z = np.random.default_rng(9).standard_normal((1, 600, 6))
    want = x @ dyn.a.T + u @ dyn.b.T + z[0] @ dyn.q_chol.T
    np.testing.assert_allclose(b.pf.particles[0], want, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(b.pf.applied[0], u[:, :2])
    keep = lab == 1  # only cluster 1 survives: every particle then is of cluster 1 with one of its offsets
    b.pf.logw = np.where(keep, 0.0, -np.inf)[None] - np.log(keep.sum())
    offsets = b.pf.offset[0, keep]
    b.pf.resample(np.random.default_rng(4), 1.0)
    assert (b.pf.label[0] == 1).all()
    assert np.isin(b.pf.offset[0, :, 0], offsets[:, 0]).all()
    # fresh particles join the cluster whose plan's state now is nearest in [x, y, vx, vy],
    # cluster 0 and 2 though no kept particle is theirs: 0 and 2 share a place and differ in heading
    b.nominal[0] = 0.0
    b.nominal[0, 1, :2] = 500.0
    b.nominal[0, 0, 3], b.nominal[0, 2, 4] = 10.0, 10.0
    fresh = np.zeros((1, 300, 6))
    fresh[0, :100, :2] = 490.0
    fresh[0, 100:200, 3], fresh[0, 200:, 4] = 9.0, 9.0
    b.reseed(np.array([0]), fresh)
    np.testing.assert_array_equal(b.pf.label[0, 300:], np.repeat([1, 0, 2], 100))
    np.testing.assert_array_equal(b.pf.offset[0, 300:], 0.0)


def test_route_switch_takes_a_nearest_cluster_and_flies_its_model():
    """``route_switch = 1``: every particle takes one of its cluster's 3 nearest others,
    drawn alike.  Reference starts at x = 0, 1, 3, 6, 20 and 0.5 (unit scale), the last
    empty: cluster 0's nearest are 1, 2 and 3 (the empty one and x = 20 are never taken), each
    drawn by a third of 3000 particles (within 4 binomial standard deviations).  Whatever it
    draws, a particle keeps its start (cluster start plus offset) and the noise it gathered
    (its state less its cluster's plan and gains at its start): it moves to where the new
    cluster's model puts that start.  A prediction steps the clusters' plan paths with the
    particles, so a noise-free particle stays on its model."""
    n = 3000
    b = ParticleBelief(np.random.default_rng(1), np.zeros((1, 6)), np.eye(6)[None], n, 0.5, 0.0, ("T1",),
                       route_switch=1.0)
    b.pf.particles[:] = 0.0
    b.pf.particles[0, :, 0] = np.linspace(-0.4, 0.2, n)  # all in cluster 0's cell
    means = np.zeros((1, 6, 6))
    means[0, :, 0] = [0.0, 1.0, 3.0, 6.0, 20.0, 0.5]
    live = np.array([[True] * 5 + [False]])
    b.commit(6, (means, np.broadcast_to(np.eye(6), (1, 6, 6, 6)), np.ones((1, 4)), live))
    assert (b.pf.label == 0).all()
    np.testing.assert_array_equal(b.neighbours[0, :3], [[1, 2, 3], [0, 2, 3], [1, 0, 3]])
    rng = np.random.default_rng(2)
    b.nominal, b.sens = rng.normal(size=(1, 6, 6)) * 50.0, rng.normal(size=(1, 6, 6, 4))
    # the noise gathered so far, wide enough that no switch jumps farther than the cloud is wide (SWITCH_SUPPORT)
    b.pf.particles += rng.normal(size=b.pf.particles.shape) * 1000.0

    def start_and_noise():
        lab, off = b.pf.label[0], b.pf.offset[0]
        model = b.nominal[0, lab] + np.einsum("nij,nj->ni", b.sens[0, lab], off)
        return b.origins[0, lab][:, [0, 1, 3, 4]] + off, b.pf.particles[0] - model

    before = start_and_noise()
    b._switch_routes()
    for got, want in zip(start_and_noise(), before):
        np.testing.assert_allclose(got, want, atol=1e-9)
    counts = np.bincount(b.pf.label[0], minlength=6)
    assert counts[[0, 4, 5]].tolist() == [0, 0, 0]
    np.testing.assert_array_less(np.abs(counts[1:4] / n - 1 / 3), 4 * math.sqrt(2 / 9 / n))
    # the plans' paths step on with the particles: noise-free, a particle stays on its cluster's model
    b.route_switch = 0.0
    b.pf.particles = b.nominal[0, b.pf.label[0]][None] + np.einsum("nij,nj->ni", b.sens[0, b.pf.label[0]],
                                                                   b.pf.offset[0])[None]
    dyn = Dynamics(1.0, 0.2, 1300.0, np.diag([1e-20] * 6))
    b.predict_committed(dyn, rng.uniform(-3000, 3000, (1, 6, 3)), rng.normal(size=(1, 6, 3, 4)) * 50.0)
    np.testing.assert_allclose(start_and_noise()[1], 0.0, atol=1e-6)


def test_a_route_switch_that_jumps_farther_than_the_cloud_is_wide_is_refused():
    """The geometry above, every particle but three in cluster 0 near x = 0 (spread 1 m),
    cluster 2's model 500 m away and the others' at the cloud: the third of the particles
    that draw cluster 2 stay as they were (label, offset and state), the rest switch.  The
    three on cluster 2 (near x = 500, with it) switch back into the cloud: their jumps are
    long but land inside it.  The gate by hand: four equally weighted points at (+-1, +-1)
    + 40 have mean (40, 40) and covariance I, so from the mean a step (3.7, 0) is within
    SWITCH_SUPPORT = 13.8 (3.7^2 = 13.69) and (3.72, 0) is not (13.84); from (40, 40) +
    (-3.72, 0) the same step (3.72, 0) lands on the mean and is; from (40, 40) + (-100, 0) a
    step (96.3, 0) lands 3.7 short and is, (96.28, 0) lands 3.72 short and is not; from
    (40, 40) + (3.7, 0) a step (3.7, 0) is short but lands 7.4 out, and is (the landing
    test alone would refuse it, the length test alone the third and fourth)."""
    square = np.array([[[1.0, 1.0], [1.0, -1.0], [-1.0, 1.0], [-1.0, -1.0]]]) + 40.0
    starts = 40.0 + np.array([[0.0, 0.0], [0.0, 0.0], [-3.72, 0.0], [-100.0, 0.0], [-100.0, 0.0], [3.7, 0.0]])
    steps = np.array([[3.7, 0.0], [3.72, 0.0], [3.72, 0.0], [96.3, 0.0], [96.28, 0.0], [3.7, 0.0]])
    got = within_spread(square, np.full((1, 4), 0.25), np.zeros(6, int), starts, steps)
    assert got.tolist() == [True, False, True, True, False, True]
    n = 3000
    b = ParticleBelief(np.random.default_rng(1), np.zeros((1, 6)), np.eye(6)[None], n, 0.5, 0.0, ("T1",),
                       route_switch=1.0)
    b.pf.particles[:] = 0.0
    b.pf.particles[0, :, 0] = np.linspace(-0.4, 0.2, n)
    means = np.zeros((1, 6, 6))
    means[0, :, 0] = [0.0, 1.0, 3.0, 6.0, 20.0, 0.5]
    b.commit(6, (means, np.broadcast_to(np.eye(6), (1, 6, 6, 6)), np.ones((1, 4)), np.array([[True] * 5 + [False]])))
    b.pf.particles[0, :, :2] += np.random.default_rng(2).normal(size=(n, 2))
    b.nominal = means.copy()  # each cluster's model at its own start ...
    b.nominal[0, 2, 0] = 500.0  # ... but cluster 2's, which has run off
    b.pf.label[0, :3] = 2  # three particles that ran off with it: x about 500, the cloud 16 m wide in x
    b.pf.particles[0, :3, 0] += 500.0 - 3.0
    before, offset = b.pf.particles.copy(), b.pf.offset.copy()
    b._switch_routes()
    counts = np.bincount(b.pf.label[0], minlength=6)
    assert counts[2] == 0
    np.testing.assert_array_less(np.abs(counts[[0, 1, 3]] / n - 1 / 3), 4 * math.sqrt(2 / 9 / n))
    stayed = (b.pf.label[0] == 0) & (np.arange(n) >= 3)
    np.testing.assert_array_equal(b.pf.particles[0, stayed], before[0, stayed])
    np.testing.assert_array_equal(b.pf.offset[0, stayed], offset[0, stayed])
    # the run-off three jump 490-500 m back into the cloud, a jump 30 widths long that lands inside
    np.testing.assert_array_less(np.abs(b.pf.particles[0, :3, 0]), 10.0)


def test_particle_filter_matches_kalman_on_linear_gaussian_toy():
    """Eq. (1) dynamics, measurement z = (p_x, p_y) + N(0, 25 I), ten steps.  With N
    particles and ESS >= N / 2 after each resampling, one step's Monte-Carlo error has
    standard deviation about sqrt(P / (N / 2)) on the mean and sqrt(2 / (N / 2))
    (relative) on a variance; up to 10 steps of such errors add, so the tolerances are
    6 sqrt(10 P / (N / 2)) and 6 sqrt(20 / (N / 2)).  Over seeds 0-19 the largest
    errors used 39% (mean) and 28% (variance) of them."""
    dyn = Dynamics(1.0, 0.2, 1300.0, np.diag([30, 30, 1e-10, 3, 3, 1e-10]))
    mu0 = np.array([100.0, 200.0, 0, 5, -3, 0])
    p0 = np.diag([200, 200, 1e-10, 20, 20, 1e-10])
    h = np.zeros((2, 6))
    h[0, 0] = h[1, 1] = 1.0
    r = 25.0 * np.eye(2)
    rng = np.random.default_rng(5)
    u = np.column_stack([rng.uniform(-3000, 3000, (10, 2)), np.zeros(10)])
    truth, zs = mu0.copy(), []
    for k in range(10):
        truth = dyn.step(truth, u[k], rng)
        zs.append(h @ truth + rng.normal(0, 5, 2))
    mu_kf, p_kf = kalman(mu0, p0, dyn.a, dyn.b, dyn.q, u, h, r, zs)

    n = 40_000
    pf = ParticleFilter.from_priors(rng, mu0[None], p0[None], n)
    for k in range(10):
        pf.predict(rng, dyn.a, dyn.b, dyn.q_chol, u[k][None])
        resid = zs[k][None, None, :] - pf.particles[..., :2]
        pf.update(-0.5 * (resid**2).sum(-1) / 25.0)
        pf.resample(rng, 0.5)
    mean, cov = pf.moments()
    sd = np.sqrt(np.diag(p_kf))[[0, 1, 3, 4]]
    np.testing.assert_array_less(np.abs(mean[0] - mu_kf)[[0, 1, 3, 4]], 6 * sd * np.sqrt(10 / (n / 2)))
    var_kf, var_pf = np.diag(p_kf)[[0, 1, 3, 4]], np.diag(cov[0])[[0, 1, 3, 4]]
    np.testing.assert_array_less(np.abs(var_pf / var_kf - 1), 6 * np.sqrt(20 / (n / 2)))


def test_roughening_adds_the_specified_jitter():
    """Resampling with roughening K adds N(0, (K E N^(-1/d))^2) per dimension, E the
    particles' spread in that dimension [Gordon1993].  Particles on a
    grid with unit spread, one weight of ~1: every resampled particle is that one, so
    the sample variance after roughening estimates the jitter variance (5 se band)."""
    n, d, k = 20_000, 6, 0.2
    rng = np.random.default_rng(9)
    p = np.tile(np.linspace(0.0, 1.0, n)[:, None], (1, d))[None]  # spread E = 1 per dimension
    logw = np.full((1, n), -1e3)
    logw[0, 123] = 0.0
    chosen = p[0, 123].copy()
    pf = ParticleFilter(p.copy(), logw)
    assert pf.resample(rng, threshold=0.5, roughening=k).tolist() == [True]
    sd = k * 1.0 * n ** (-1.0 / d)
    var = pf.particles[0].var(axis=0)
    np.testing.assert_array_less(np.abs(var / sd**2 - 1), 5 * np.sqrt(2 / n))
    np.testing.assert_allclose(pf.particles[0].mean(axis=0), chosen, atol=5 * sd / np.sqrt(n))


def test_noise_levels_scale_each_particles_noise_and_follow_resampling():
    """Jump-Markov process noise: with scales (0.25, 1) and no switching, the particles of
    level 0 move by noise of standard deviation 0.5 and the others by 1 (20 000 particles:
    s.e. of a standard deviation under 0.4%, tolerance 4%); resampling onto the level-0
    particles leaves only level 0; with switch = 1 each particle redraws its level, half
    of them level 0 (s.e. 0.0035, tolerance 0.02)."""
    rng = np.random.default_rng(5)
    n = 20_000
    pf = ParticleFilter.from_priors(rng, np.zeros((1, 6)), np.eye(6)[None], n, np.array([0.25, 1.0]), 0.0)
    before, mode = pf.particles.copy(), pf.mode.copy()
    pf.predict(rng, np.eye(6), np.zeros((6, 3)), np.eye(6), np.zeros((1, 3)))
    step = pf.particles - before
    np.testing.assert_allclose([step[0, mode[0] == 0].std(), step[0, mode[0] == 1].std()], [0.5, 1.0], rtol=0.04)
    pf.logw = np.where(mode == 0, 0.0, -np.inf) - np.log(np.count_nonzero(mode == 0))
    pf.resample(rng, 1.0)
    assert np.all(pf.mode == 0)
    pf.switch = 1.0
    pf.predict(rng, np.eye(6), np.zeros((6, 3)), np.eye(6), np.zeros((1, 3)))
    assert abs(np.mean(pf.mode == 0) - 0.5) < 0.02


def test_one_noise_scale_multiplies_every_particles_q():
    """``noise_scales = [0.25]``: every particle's noise has standard deviation 0.5 (it used
    to be ignored, every particle moving by Q; 20 000 particles, s.e. of a standard
    deviation under 0.4%, tolerance 4%); ``[1.0]`` (the paper's) draws exactly what no
    scales draw."""
    n = 20_000
    pf = ParticleFilter.from_priors(np.random.default_rng(5), np.zeros((1, 6)), np.eye(6)[None], n, np.array([0.25]))
    before = pf.particles.copy()
    pf.predict(np.random.default_rng(6), np.eye(6), np.zeros((6, 3)), np.eye(6), np.zeros((1, 3)))
    np.testing.assert_allclose((pf.particles - before).std(), 0.5, rtol=0.04)
    moved = []
    for scales in (np.array([1.0]), None):
        pf = ParticleFilter.from_priors(np.random.default_rng(5), np.zeros((1, 6)), np.eye(6)[None], 50, scales)
        pf.predict(np.random.default_rng(6), np.eye(6), np.zeros((6, 3)), np.eye(6), np.zeros((1, 3)))
        moved.append(pf.particles)
    np.testing.assert_array_equal(*moved)


def test_noise_shares_set_each_levels_chance():
    """``noise_shares = (0.5, 0.4, 0.1)``: 20 000 particles draw levels 0, 1, 2 at those
    chances (binomial s.e. at most 0.0035, tolerance 0.02) at the start and when they
    switch; equal shares draw exactly what no shares draw (the integers of the paper's
    filter, so runs with alike levels stay as they were)."""
    n = 20_000
    scales, shares = np.array([0.003, 0.03, 0.3]), np.array([0.5, 0.4, 0.1])
    pf = ParticleFilter.from_priors(np.random.default_rng(5), np.zeros((1, 6)), np.eye(6)[None], n, scales, 1.0,
                                    shares=shares)
    np.testing.assert_allclose(np.bincount(pf.mode[0], minlength=3) / n, shares, atol=0.02)
    pf.predict(np.random.default_rng(6), np.eye(6), np.zeros((6, 3)), np.eye(6), np.zeros((1, 3)))
    np.testing.assert_allclose(np.bincount(pf.mode[0], minlength=3) / n, shares, atol=0.02)
    modes = [ParticleFilter.from_priors(np.random.default_rng(5), np.zeros((1, 6)), np.eye(6)[None], 50, scales,
                                        shares=sh).mode for sh in (np.full(3, 1 / 3), None)]
    np.testing.assert_array_equal(*modes)


def _committed_belief(noise_space: str, scales: np.ndarray, n: int = 20_000) -> ParticleBelief:
    """One target's cloud, committed in one cluster, with noise levels ``scales``."""
    cov = np.diag([400.0, 100.0, 1e-10, 4.0, 9.0, 1e-10])
    b = ParticleBelief(np.random.default_rng(3), np.zeros((1, 6)), cov[None], n, 0.5, 0.0, ("T1",),
                       noise_scales=scales, noise_space=noise_space)
    b.commit(1)
    return b


def test_start_noise_moves_the_start_and_the_state_by_the_plans_response():
    """``noise_space = "start"`` with one level 0.25 and the default Q = diag(30, 30, ~0, 3, 3, ~0): each
    particle's start offset moves by noise of variance 0.25 x Q's [x, y, vx, vy] block
    (20 000 particles: relative s.e. of a variance 1%, tolerance 5%) and its state by the
    committed plan's response: after one step with zero forces and gains the state is A
    times (start + that noise), i.e. ``G_1 = A E``; after a second step with gains K it is
    ``G_2 = A G_1 + B K`` that maps the second step's start noise into the state.  With
    ``G = 0`` (a plan converged on its goal point) the start moves and the state does not."""
    dyn = Dynamics()
    b = _committed_belief("start", np.array([0.25]))
    x0, d0 = b.pf.particles.copy(), b.pf.offset.copy()
    b.predict_committed(dyn, np.zeros((1, 1, 3)), np.zeros((1, 1, 3, 4)))
    step = b.pf.offset - d0
    np.testing.assert_allclose(step[0].var(axis=0), 0.25 * np.array([30.0, 30.0, 3.0, 3.0]), rtol=0.05)
    moved = x0.copy()
    moved[..., [0, 1, 3, 4]] += step
    np.testing.assert_allclose(b.pf.particles, moved @ dyn.a.T, atol=1e-9)
    gains = np.random.default_rng(4).normal(size=(1, 1, 3, 4)) * 100.0
    g1 = b.sens.copy()
    np.testing.assert_allclose(g1[0, 0], dyn.a[:, [0, 1, 3, 4]], atol=1e-15)
    x1, d1 = b.pf.particles.copy(), b.pf.offset.copy()
    b.predict_committed(dyn, np.zeros((1, 1, 3)), gains)
    own = np.einsum("ij,nj->ni", gains[0, 0], b.pf.offset[0])
    want = (x1[0] + (b.pf.offset[0] - d1[0]) @ g1[0, 0].T) @ dyn.a.T + own @ dyn.b.T
    np.testing.assert_allclose(b.pf.particles[0], want, atol=1e-9)
    np.testing.assert_allclose(b.sens[0, 0], dyn.a @ g1[0, 0] + dyn.b @ gains[0, 0], atol=1e-12)
    b.sens[:] = 0.0
    x2, d2 = b.pf.particles.copy(), b.pf.offset.copy()
    b.predict_committed(Dynamics(friction=0.0), np.zeros((1, 1, 3)),
                        np.zeros((1, 1, 3, 4)))
    assert not np.allclose(b.pf.offset, d2)
    np.testing.assert_allclose(b.pf.particles[0], x2[0] @ Dynamics(friction=0.0).a.T, atol=1e-9)


def test_split_noise_sends_the_highest_level_to_the_state_and_the_others_to_the_start():
    """``noise_space = "split"``, levels (0.01, 1): the level-1 particles' starts stay and
    their states take Q's noise (variance 30 in x: 10 000 particles, tolerance 5%); the
    level-0.01 particles' starts move by 0.01 Q and their states by the plan's response
    only (here ``G_0 = E``, so state less start is unchanged).  ``"state"`` moves no start;
    ``"split"`` keeps the highest level in the state wherever it is listed, and the only
    level of one."""
    dyn = Dynamics(friction=0.0)
    b = _committed_belief("split", np.array([0.01, 1.0]))
    top = b.pf.mode[0] == 1
    x0, d0 = b.pf.particles.copy(), b.pf.offset.copy()
    b.predict_committed(dyn, np.zeros((1, 1, 3)), np.zeros((1, 1, 3, 4)))
    dd = (b.pf.offset - d0)[0]
    assert not dd[top].any()
    np.testing.assert_allclose(dd[~top].var(axis=0), 0.01 * np.array([30.0, 30.0, 3.0, 3.0]), rtol=0.05)
    drift = (b.pf.particles - x0 @ dyn.a.T)[0]
    np.testing.assert_allclose(drift[top, 0].var(), 30.0, rtol=0.05)
    np.testing.assert_allclose(drift[~top][:, [0, 1, 3, 4]], dd[~top] @ dyn.a[np.ix_([0, 1, 3, 4], [0, 1, 3, 4])].T,
                               atol=1e-9)
    for space, scales in (("state", [0.01, 1.0]), ("split", [1.0, 0.01]), ("split", [0.5])):
        b = _committed_belief(space, np.array(scales), 200)
        top = b.pf.mode[0] == 0 if len(scales) > 1 else np.ones(200, bool)
        d0 = b.pf.offset.copy()
        b.predict_committed(dyn, np.zeros((1, 1, 3)), np.zeros((1, 1, 3, 4)))
        moved = (b.pf.offset != d0)[0].any(axis=1)
        np.testing.assert_array_equal(moved, ~top if space == "split" else np.zeros(200, bool))


def test_a_draw_from_the_belief_picks_particles_by_weight():
    """Weights 0.5, 0.3, 0.2, 0 on four particles (and one target of weight 1 on its
    last): 40 000 draws pick each at its weight within 4 binomial s.e. (at most 0.0025),
    never the weightless one; a Gaussian belief's draws have its mean and covariance
    (4 s.e. of 40 000 draws; the covariance's worst relative s.e. is its cross term's,
    sqrt((100 x 25 + 30^2) / k) / 30 = 1%) though its z block is 1e-10."""
    particles = np.arange(2 * 4 * 6, dtype=float).reshape(2, 4, 6)
    logw = np.log(np.array([[0.5, 0.3, 0.2, 1e-300], [1e-300, 1e-300, 1e-300, 1.0]]))
    belief = ParticleBelief(np.random.default_rng(0), np.zeros((2, 6)), np.tile(np.eye(6), (2, 1, 1)), 4, 0.5, 0.0,
                            ("A", "B"))
    belief.pf.particles, belief.pf.logw = particles, logw
    k = 40_000
    got = belief.draw(np.random.default_rng(1), k)
    assert got.shape == (2, k, 6)
    share = (got[0, :, 0][:, None] == particles[0, :, 0]).mean(axis=0)
    np.testing.assert_allclose(share, [0.5, 0.3, 0.2, 0.0], atol=4 * np.sqrt(0.25 / k))
    assert (got[1] == particles[1, 3]).all()
    cov = np.diag([100.0, 25.0, 1e-10, 4.0, 1.0, 1e-10])
    cov[0, 1] = cov[1, 0] = 30.0
    gauss = GaussianBelief("plkf", np.array([[10.0, -5.0, 0.0, 1.0, 2.0, 0.0]]), cov[None], 16.0, ("A",))
    x = gauss.draw(np.random.default_rng(2), k)[0]
    np.testing.assert_allclose(x.mean(axis=0)[:2], [10.0, -5.0], atol=4 * np.sqrt(100.0 / k))
    np.testing.assert_allclose(np.cov(x[:, :2].T), cov[:2, :2], rtol=0.04)  # relative s.e. <= 1% (sqrt(3400 / k) / 30)


def test_each_particle_keeps_the_force_it_moved_by_through_resampling_and_reseeding():
    """What the link term's next re-plans weigh against: after a split prediction each
    particle keeps its half's force, the belief's means of it are the weighted means by
    hand (cloud and halves), resampling carries a particle's force with it, and re-seeded
    particles take the mean force of the particles kept."""
    b = _belief_on(np.array([0.0, 0.0]), 5.0, 10.0)
    n = b.pf.particles.shape[1]
    mask = (np.arange(n) % 4 == 0)[None]  # a quarter of the cloud is the second half
    b.predict(Dynamics(), np.array([[100.0, -200.0, 0.0]]), (mask, np.array([[-300.0, 50.0, 0.0]])))
    np.testing.assert_array_equal(b.pf.applied[0, mask[0]], np.broadcast_to([-300.0, 50.0], (n // 4, 2)))
    np.testing.assert_array_equal(b.pf.applied[0, ~mask[0]], np.broadcast_to([100.0, -200.0], (n - n // 4, 2)))
    w = np.random.default_rng(3).dirichlet(np.ones(n))
    b.pf.logw = np.log(w)[None]
    share = w[mask[0]].sum()
    first, second = np.array([100.0, -200.0]), np.array([-300.0, 50.0])
    np.testing.assert_allclose(b.applied()[0], (1 - share) * first + share * second)
    np.testing.assert_allclose(b.applied(mask)[0], [[100.0, -200.0], [-300.0, 50.0]])
    b.pf.logw = np.where(mask, 0.0, -np.inf) - np.log(n // 4)  # only the second half survives
    b.pf.resample(np.random.default_rng(4), 1.0)
    np.testing.assert_array_equal(b.pf.applied[0], np.broadcast_to([-300.0, 50.0], (n, 2)))
    b.pf.applied[0, : n // 2] = [0.0, 0.0]
    b.reseed(np.array([0]), np.zeros((1, n // 2, 6)))
    kept = b.pf.applied[0, : n - n // 2]
    np.testing.assert_allclose(b.pf.applied[0, n - n // 2:], np.broadcast_to(kept.mean(axis=0), (n // 2, 2)))


def test_a_restricted_prior_is_the_gaussian_truncated():
    """:func:`restricted_draws`: target 0 ~ N(0, 4 I) kept where x >= 1 (a share 1 - Phi(0.5) =
    0.31 of its draws), target 1 ~ N(0, I) where y <= 0.  Every draw is kept by the test,
    and the kept x has the truncated normal's mean ``2 phi(0.5) / (1 - Phi(0.5)) = 2.2827``
    (standard error 1.036 / sqrt(n) = 0.0073; tolerance 4 of them); the coordinates the
    test does not see keep mean 0.  Without a test the draws are the plain prior's."""
    n, rng = 20000, np.random.default_rng(5)
    covs = np.stack([4 * np.eye(6), np.eye(6)])

    def clear(x):
        return np.stack([x[0, :, 0] >= 1.0, x[1, :, 1] <= 0.0])

    x, unrestricted = restricted_draws(rng, np.zeros((2, 6)), covs, n, clear)
    assert x.shape == (2, n, 6) and unrestricted.tolist() == [0, 0] and clear(x).all()
    assert abs(x[0, :, 0].mean() - 2.2827) < 4 * 0.0073
    assert abs(x[1, :, 1].mean() + math.sqrt(2 / math.pi)) < 4 * 0.60 / math.sqrt(n)
    assert abs(x[0, :, 1].mean()) < 4 * 2 / math.sqrt(n) and abs(x[1, :, 0].mean()) < 4 / math.sqrt(n)
    plain, _ = restricted_draws(np.random.default_rng(6), np.zeros((2, 6)), covs, 50)
    np.testing.assert_array_equal(plain, ParticleFilter.from_priors(np.random.default_rng(6), np.zeros((2, 6)),
                                                                    covs, 50).particles)


def test_a_prior_that_cannot_be_restricted_is_reported():
    belief = ParticleBelief(np.random.default_rng(1), np.zeros((2, 6)), np.tile(np.eye(6), (2, 1, 1)), 100, 0.5,
                            0.0, ("T1", "T2"), clear=lambda x: np.stack([np.zeros(x.shape[1], bool),
                                                                         np.ones(x.shape[1], bool)]))
    notes = belief.drain_notes()
    assert len(notes) == 1 and notes[0].startswith("T1: 100 of 100 prior particles not restricted")
    assert belief.drain_notes() == []


@pytest.mark.parametrize("threshold", [0.3, 0.9])
def test_keep_out_weighs_the_particles_inside_zero(threshold):
    """Target 0's particles with x > 0 (about half) are inside: they weigh zero and the rest
    keep their ratios; below the ESS threshold (0.9 here) the cloud is resampled from the
    outside ones.  Target 1's particles are all inside: its weights stay, reported."""
    rng = np.random.default_rng(2)
    belief = ParticleBelief(rng, np.zeros((2, 6)), np.tile(np.eye(6), (2, 1, 1)), 1000, threshold, 0.0,
                            ("T1", "T2"))
    w0 = belief.pf.weights.copy()
    events = belief.keep_out(lambda p: np.stack([p[0, :, 0] > 0, np.ones(p.shape[1], bool)]))
    assert events[0] == "T2: every particle inside an obstacle after the prediction; weights kept"
    np.testing.assert_array_equal(belief.pf.weights[1], w0[1])
    if threshold == 0.3:
        out = belief.pf.particles[0, :, 0] <= 0
        assert len(events) == 1 and (belief.pf.weights[0][~out] == 0).all()
        np.testing.assert_allclose(belief.pf.weights[0][out], 1 / out.sum())
    else:
        assert events[1] == "resampled T1 (particles inside obstacles)"
        assert (belief.pf.particles[0, :, 0] <= 0).all()
        np.testing.assert_allclose(belief.pf.weights[0], 1e-3)
