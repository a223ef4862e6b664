"""Bearing sensor ([Papaioannou2023, Eq. (4), Sec. III-C]): convention by hand, statistics with seeds.

Statistical tolerances are 5 standard errors of the estimator for the sample size used,
so a correct sensor fails with probability below 1e-6 per check.
"""

import numpy as np
import pytest

from uavsim.sensing import BearingModel, MeasurementModel, bearing, observe, wrap_angle

PI = np.pi


@pytest.mark.parametrize(
    "dx, dy, expect",
    [
        (0, 1, 0.0),  # north
        (1, 1, PI / 4),  # north-east: clockwise from north
        (1, 0, PI / 2),  # east
        (1, -1, 3 * PI / 4),  # south-east
        (0, -1, PI),  # south is +pi, never -pi
        (-1, -1, -3 * PI / 4),  # south-west
        (-1, 0, -PI / 2),  # west
        (-1, 1, -PI / 4),  # north-west
        (3, 4, np.arctan2(3, 4)),  # 36.87 deg
    ],
)
def test_bearing_convention_all_quadrants(dx, dy, expect):
    sensor = np.array([100.0, 200.0, 40.0])
    target = sensor + np.array([dx, dy, -40.0])
    assert bearing(target, sensor) == pytest.approx(expect, abs=1e-15)


def test_south_with_negative_zero_is_plus_pi():
    assert bearing(np.array([-0.0, -1.0]), np.array([0.0, 0.0])) == PI


def test_wrap_angle_range():
    a = np.array([-PI, PI, 3 * PI, -3 * PI, 0.5, -0.5 - 2 * PI, 7.0])
    np.testing.assert_allclose(wrap_angle(a), [PI, PI, PI, PI, 0.5, -0.5, 7.0 - 2 * PI], atol=1e-12)
    w = wrap_angle(np.linspace(-20, 20, 100001))
    assert np.all(w > -PI) and np.all(w <= PI)


N_CHANNELS = 200_000  # channels are independent, so one scan of many channels is many scans


def scan_many(sensor, seed=11):
    rng = np.random.default_rng(seed)
    angles = rng.uniform(-PI, PI, N_CHANNELS)
    targets = np.column_stack([500 + 300 * np.sin(angles), 500 + 300 * np.cos(angles), np.zeros(N_CHANNELS)])
    observer = np.array([500.0, 500.0, 40.0])
    return observe(rng, sensor, targets, observer), bearing(targets, observer)


@pytest.mark.parametrize("rate", [1.0, 8.0])
def test_clutter_count_mean_and_variance(rate):
    sensor = BearingModel(sigma=np.radians(1.0), p_detect=0.95, clutter_rate=rate)
    scan, _ = scan_many(sensor)
    n = N_CHANNELS
    clutter = (scan.valid & ~scan.from_target).sum(axis=1)
    assert abs(clutter.mean() - rate) < 5 * np.sqrt(rate / n)
    # Var of the sample variance of Poisson(L): (mu4 - sigma^4) / n = (L + 2 L^2) / n
    assert abs(clutter.var() - rate) < 5 * np.sqrt((rate + 2 * rate**2) / n)


def test_detection_frequency_and_residual_std():
    sigma = np.radians(1.0)
    sensor = BearingModel(sigma=sigma, p_detect=0.95, clutter_rate=1.0)
    scan, truth = scan_many(sensor)
    n = N_CHANNELS
    detected = scan.from_target.any(axis=1)
    assert abs(detected.mean() - 0.95) < 5 * np.sqrt(0.95 * 0.05 / n)
    assert np.all(scan.from_target.sum(axis=1) <= 1)
    resid = wrap_angle(scan.bearings[:, 0][detected] - truth[detected])
    assert abs(resid.mean()) < 5 * sigma / np.sqrt(detected.sum())
    assert abs(resid.std() - sigma) < 5 * sigma / np.sqrt(2 * detected.sum())


def test_clutter_uniform_on_circle():
    """Clutter bearings in (-pi, pi], each quarter with probability 1/4 (5 se)."""
    sensor = BearingModel(sigma=np.radians(1.0), p_detect=0.0, clutter_rate=2.0)
    scan, _ = scan_many(sensor)
    c = scan.bearings[scan.valid]
    assert not scan.from_target.any()
    assert np.all(c > -PI) and np.all(c <= PI)
    frac = np.histogram(c, bins=4, range=(-PI, PI))[0] / c.size
    assert np.all(np.abs(frac - 0.25) < 5 * np.sqrt(0.25 * 0.75 / c.size))


def test_no_clutter_full_detection_shape_and_determinism():
    sensor = BearingModel(sigma=0.01, p_detect=1.0, clutter_rate=0.0)
    t = np.array([[0.0, 10.0, 0.0], [10.0, 0.0, 0.0]])
    s = np.array([0.0, 0.0, 40.0])
    a = observe(np.random.default_rng(3), sensor, t, s)
    b = observe(np.random.default_rng(3), sensor, t, s)
    assert a.bearings.shape == (2, 1) and a.valid.all() and a.from_target.all()
    np.testing.assert_array_equal(a.bearings, b.bearings)
    np.testing.assert_allclose(a.bearings[:, 0], [0.0, PI / 2], atol=0.05)


# --------------------------------------------------------------------------- line of sight
def _block_world():
    """One 20 m cuboid block at x 40..60, y 90..110, 0..30 m high, in a 200 m area."""
    from uavsim.world import World

    return World("block", np.zeros(3), np.array([200.0, 200.0, 100.0]), np.array([[40.0, 90.0, 0.0]]),
                 np.array([[60.0, 110.0, 30.0]]), ("block",), ())


def _los(p_detect=0.9, clutter=1.0):
    return BearingModel(np.radians(1.0), p_detect, clutter, line_of_sight=True, world=_block_world())


UAV = np.array([0.0, 100.0, 20.0])  # west of the block, below its roof
HIDDEN, SEEN = np.array([100.0, 100.0, 0.0]), np.array([100.0, 20.0, 0.0])  # east of it; south-east, clear


def test_line_of_sight_blocks_by_hand():
    s = _los()
    assert s.visible(np.array([HIDDEN, SEEN]), UAV).tolist() == [False, True]
    assert s.visible(HIDDEN, UAV + [0, 0, 200.0])  # from 220 m the roof no longer hides it
    np.testing.assert_array_equal(s.detection(np.array([HIDDEN, SEEN]), UAV), [0.0, 0.9])
    off = BearingModel(np.radians(1.0), 0.9, 1.0, world=_block_world())
    assert off.detection(HIDDEN, UAV) == 0.9 and off.visible(HIDDEN, UAV)


def test_hidden_target_is_never_detected_and_clutter_is_unchanged():
    """The same seed gives the same clutter with and without line of sight; the hidden
    target's bearing is never in its scan (500 scans, p_D = 1)."""
    on, off = _los(1.0, 2.0), BearingModel(np.radians(1.0), 1.0, 2.0)
    targets = np.array([HIDDEN, SEEN])
    for seed in range(500):
        a = on.draw(np.random.default_rng(seed), targets, UAV)
        b = off.draw(np.random.default_rng(seed), targets, UAV)
        assert not a.from_target[0].any() and a.from_target[1, 0] and a.blocked.tolist() == [True, False]
        clutter = b.bearings[0][b.valid[0] & ~b.from_target[0]]
        np.testing.assert_array_equal(np.sort(a.bearings[0][a.valid[0]]), np.sort(clutter))


def test_a_missed_scan_favours_hidden_particles_by_one_over_one_minus_pd():
    """Eq. (10) with p_D at each particle, by hand: an empty scan has likelihood
    ``(1 - p_D) e^-L`` where the sensor sees and ``e^-L`` behind the block; with two false
    alarms a hidden particle has ``e^-L (L / 2 pi)^2``."""
    from uavsim.sensing import Scan

    s, lam = _los(0.9, 1.5), 1.5
    particles = np.array([[HIDDEN, SEEN]])
    empty = Scan(np.zeros((1, 0)), np.zeros((1, 0), bool), np.zeros((1, 0), bool))
    np.testing.assert_allclose(s.log_likelihood(empty, particles, UAV), [[-lam, np.log(0.1) - lam]], rtol=1e-12)
    two = Scan(np.array([[0.3, -2.0]]), np.ones((1, 2), bool), np.zeros((1, 2), bool))
    assert s.log_likelihood(two, particles, UAV)[0, 0] == pytest.approx(2 * np.log(lam / (2 * PI)) - lam, rel=1e-12)


def test_traces_under_line_of_sight_mix_detection_and_miss():
    """Without obstacles the line-of-sight traces are ``p_D tr(det) + (1 - p_D) tr(prior)``,
    tr(det) the paper's Eq. (12) (the fast path); behind the block every candidate that
    cannot see the cloud scores the prior's trace."""
    from uavsim.belief.traces import bearing_traces, pseudo_traces

    rng = np.random.default_rng(4)
    particles = np.array([HIDDEN, SEEN])[:, None, :] + rng.normal(size=(2, 800, 3)) * [6.0, 6.0, 0.0]
    particles = np.concatenate([particles, np.zeros((2, 800, 3))], axis=2)
    w = rng.dirichlet(np.ones(800), size=2)
    cands = np.array([UAV, UAV + [0, -70.0, 0], [150.0, 180.0, 20.0]])
    clear = BearingModel(np.radians(1.0), 0.8, 1.0, line_of_sight=True)
    prior = np.einsum("mn,mni->mi", w, particles**2).sum(-1) - (np.einsum("mn,mni->mi", w, particles) ** 2).sum(-1)
    want = 0.8 * bearing_traces(cands, particles, w, clear.sigma) + 0.2 * prior
    np.testing.assert_allclose(pseudo_traces(cands, particles, w, clear), want, rtol=1e-6)  # the fast path: float32
    got = pseudo_traces(cands, particles, w, _los(0.8))
    assert got[0, 0] == pytest.approx(prior[0], rel=1e-6)  # the hidden cloud, seen from behind the block
    assert got[0, 1] == pytest.approx(want[0, 1], rel=1e-6)  # the clear one


def test_bound_takes_no_information_where_the_truth_is_hidden():
    """The PCRLB with line of sight: a truth always behind the block gets the prediction's
    bound (no sensor); one always in view gets the bound without line of sight."""
    from uavsim.bounds.pcrlb import pcrlb_for_trials
    from uavsim.targets import Dynamics

    dyn = Dynamics(1.0, 0.2, 1300.0, np.diag([30.0, 30, 1e-10, 3, 3, 1e-10]))
    truth = np.tile(np.concatenate([[HIDDEN, SEEN], np.zeros((2, 3))], axis=1), (2, 5, 1, 1))  # (trials, T, M, 6)
    obs = np.tile(UAV, (2, 5, 1, 1))
    cov0 = np.diag([200.0, 200, 1e-10, 20, 20, 1e-10])
    los = pcrlb_for_trials(truth, obs, dyn, cov0, _los()).pos_per_target
    plain = pcrlb_for_trials(truth, obs, dyn, cov0, BearingModel(np.radians(1.0), 0.9, 1.0)).pos_per_target
    blind = pcrlb_for_trials(truth, obs[:, :, :0], dyn, cov0, _los()).pos_per_target
    np.testing.assert_allclose(los[0], blind[0], rtol=1e-12)
    np.testing.assert_allclose(los[1], plain[1], rtol=1e-12)
    assert np.all(los[0] > plain[0])


# --------------------------------------------------------------------------- a second sensor in one class
class RangeBearing(MeasurementModel):
    """A range-bearing sensor (bearing as Eq. 4, range with its own noise), no clutter,
    detection p_D: what a new sensor adds is this class, and the filter, the traces and
    the bound take it unchanged."""

    line_of_sight = False

    def __init__(self, sigma=PI / 180, sigma_r=5.0, p_detect=0.9):
        self.sigma, self.sigma_r, self.p_detect = sigma, sigma_r, p_detect

    @property
    def noise_cov(self):
        return np.diag([self.sigma**2, self.sigma_r**2])

    def expected(self, targets, observers):
        d = np.asarray(targets)[..., :2] - np.asarray(observers)[..., :2]
        return np.stack([np.arctan2(d[..., 0], d[..., 1]), np.hypot(d[..., 0], d[..., 1])], -1)

    def residual(self, z, expected):
        r = z - expected
        return np.concatenate([wrap_angle(r[..., :1]), r[..., 1:]], -1)

    def jacobian(self, targets, observers, min_range=0.0):
        d = targets[..., :, None, :2] - observers[..., None, :, :2]
        r = np.maximum(np.hypot(d[..., 0], d[..., 1]), max(min_range, 1e-12))[..., None]
        return np.stack([np.stack([d[..., 1], -d[..., 0]], -1) / r**2, d / r], -2)  # (..., M, S, 2, 2)

    def information_factor(self):
        return self.p_detect  # clutter-free: q2 = p_D

    def draw(self, rng, targets, observer):
        from uavsim.sensing import Scan

        z = self.expected(targets, observer) + rng.standard_normal((len(targets), 2)) * [self.sigma, self.sigma_r]
        hit = rng.random(len(targets)) < self.p_detect
        return Scan(np.where(hit[:, None], z, 0.0)[:, None, :], hit[:, None], hit[:, None])

    def log_likelihood(self, scan, particles, observer):
        r = self.residual(scan.bearings[:, :1, :], self.expected(particles, observer))  # (M, N, 2)
        det = np.log(self.p_detect) - 0.5 * (r**2 / np.diag(self.noise_cov)).sum(-1) - np.log(
            2 * PI * self.sigma * self.sigma_r)
        return np.where(scan.valid[:, :1], det, np.log1p(-self.p_detect))

    def uniform_loglik(self, valid):
        return np.zeros(len(valid))


def test_a_range_bearing_model_flies_through_filter_traces_and_bound():
    from uavsim.belief.particle import ParticleBelief
    from uavsim.belief.traces import pseudo_traces
    from uavsim.bounds.pcrlb import pcrlb_for_trials
    from uavsim.targets import Dynamics

    model, rng = RangeBearing(), np.random.default_rng(7)
    truth = np.array([[300.0, 400.0, 0, 0, 0, 0]])
    obs = np.array([0.0, 0.0, 40.0])
    cov0 = np.diag([400.0, 400, 1e-10, 1, 1, 1e-10])
    # the filter: one scan pulls a 20 m prior to the range-bearing fix (about 5 m)
    belief = ParticleBelief(rng, truth + [30.0, -25, 0, 0, 0, 0], cov0[None], 20000, 0.5, 0.0, ("T1",))
    errors = []
    for _ in range(20):
        belief.update([model.draw(rng, truth[:, :3], obs)], obs[None], model)
        errors.append(np.linalg.norm(belief.moments()[0][0, :2] - truth[0, :2]))
    assert np.mean(errors[5:]) < 6.0
    # the traces: Eq. (12) by a brute-force loop over candidates and particles
    p = belief.pf.particles[:, :500]
    w = np.full((1, 500), 1 / 500)
    cands = np.array([[0.0, 0.0, 40.0], [500.0, 100.0, 40.0]])
    mean = p[0].mean(axis=0)
    want = []
    for c in cands:
        z = model.expected(mean, c)
        lik = np.array([np.exp(-0.5 * np.sum(model.residual(z, model.expected(x, c)) ** 2 / np.diag(model.noise_cov)))
                        for x in p[0]])
        q = lik / lik.sum()
        mu = q @ p[0]
        want.append(q @ ((p[0] - mu) ** 2).sum(-1))
    np.testing.assert_allclose(pseudo_traces(cands, p, w, model)[:, 0], want, rtol=1e-9)
    # the bound: J = q2 H^T R^-1 H by hand, one step
    dyn = Dynamics(1.0, 0.2, 1300.0, np.zeros((6, 6)) + np.diag([1e-10] * 6))
    b = pcrlb_for_trials(truth[None, None], obs[None, None, None], dyn, cov0, model)
    d, r = truth[0, :2] - obs[:2], np.hypot(*(truth[0, :2] - obs[:2]))
    h = np.array([[d[1], -d[0]] / r**2, d / r])
    info = 0.9 * h.T @ np.linalg.inv(model.noise_cov) @ h
    pred = (dyn.a @ cov0 @ dyn.a.T + dyn.q)[np.ix_([0, 1], [0, 1])]
    np.testing.assert_allclose(b.cov[0, 0][:2, :2], np.linalg.inv(np.linalg.inv(pred) + info), rtol=1e-6)


def test_traces_by_cells_equal_the_mix_over_every_particle(monkeypatch):
    """The fast path's traces under line of sight (cells sorted along and across each cloud,
    the last filled up with weightless copies) equal model_traces', which tests every
    particle's line of sight: with a cell per particle for a cloud a shadow's edge crosses,
    and with the default 32 cells for 999 particles wholly hidden or wholly seen from each
    candidate; every cell in one block of the sums, or a block a cell (float32 sums: 1e-4)."""
    from uavsim.belief import traces

    rng = np.random.default_rng(8)
    s = _los(0.8, 1.0)
    edge = np.zeros((1, 400, 6))
    edge[0, :, :2] = [100.0, 125.0] + rng.normal(size=(400, 2)) * [8.0, 4.0]
    edge[0, :, 3:5] = rng.normal(size=(400, 2))
    w_edge = rng.dirichlet(np.ones(400))[None]
    near = np.array([UAV, UAV + [0, 5.0, 0], UAV + [0, -8.0, 0]])
    clouds = np.zeros((2, 999, 6))
    clouds[..., :3] = np.array([HIDDEN, SEEN])[:, None] + rng.normal(size=(2, 999, 3)) * [3.0, 3.0, 0.0]
    w = rng.dirichlet(np.ones(999), size=2)
    cands = np.array([UAV, UAV + [0, -70.0, 0], [150.0, 180.0, 20.0]])
    seen = s.visible(clouds[:, None, :, :3], cands[None, :, None])  # (2, 3, 999)
    assert (seen.all(axis=2) | ~seen.any(axis=2)).all() and not seen[0, 0].any()  # one verdict a cloud; hidden from UAV
    for block in (traces.BLOCK_ELEMENTS, 1):
        monkeypatch.setattr(traces, "BLOCK_ELEMENTS", block)
        monkeypatch.setattr(traces, "SIGHT_CELLS", 400)
        np.testing.assert_allclose(traces.pseudo_traces(near, edge, w_edge, s),
                                   traces.model_traces(near, edge, w_edge, s), rtol=1e-4)
        monkeypatch.setattr(traces, "SIGHT_CELLS", 32)
        np.testing.assert_allclose(traces.pseudo_traces(cands, clouds, w, s), traces.model_traces(cands, clouds, w, s),
                                   rtol=1e-4)


def _per_particle(cands, particles, w, s) -> np.ndarray:
    """``(M, C, N)`` detection of each particle (in the original order) by its cell's verdict."""
    from uavsim.belief.traces import _gather, cell_detection, sight_cells

    n = particles.shape[1]
    order, k = sight_cells(particles, w)
    detect = cell_detection(cands, _gather(particles, order), _gather(w, order), k, s)
    out = np.empty(detect.shape[:2] + (n,), np.float32)
    cell = np.arange(n) // (order.shape[1] // k)  # the cell of each position but the copies at the end
    np.put_along_axis(out, np.broadcast_to(order[:, None, :n], out.shape), detect[..., cell], axis=2)
    return out


def test_sight_cells_take_their_tested_verdict(monkeypatch):
    """A cloud straddling the block's shadow: with a cell per particle the detection is the
    exact visibility; with 32 cells (the default) the cells' verdicts agree with it for at
    least 90% of 2000 particles, and only near the shadow's edge.  The cells are of equal
    count, the last filled up with copies of the last particle."""
    from uavsim.belief import traces

    rng = np.random.default_rng(5)
    particles = np.zeros((1, 2000, 6))
    particles[0, :, :2] = [100.0, 125.0] + rng.normal(size=(2000, 2)) * [8.0, 4.0]  # the edge: y = 125 at x = 100
    w = rng.dirichlet(np.ones(2000))[None]
    cands = np.array([UAV, UAV + [0, 5.0, 0]])
    s = _los(0.9)
    exact = 0.9 * s.visible(particles[:, None, :, :3], cands[None, :, None, :])
    monkeypatch.setattr(traces, "SIGHT_CELLS", 2000)
    assert traces.sight_cells(particles, w)[1] == 2000
    np.testing.assert_array_equal(_per_particle(cands, particles, w, s), exact.astype(np.float32))
    monkeypatch.setattr(traces, "SIGHT_CELLS", 32)
    order, k = traces.sight_cells(particles, w)
    assert k == 32 and order.shape == (1, 2016)  # 8 strips of 4 cells of 63, the last particle copied 16 times
    np.testing.assert_array_equal(np.sort(order[0, :2000]), np.arange(2000))  # a permutation, then the copies
    np.testing.assert_array_equal(order[0, 2000:], order[0, 1999])
    got = _per_particle(cands, particles, w, s)
    assert 0.2 < exact.mean() / 0.9 < 0.8  # the cloud is split by the edge
    wrong = got != exact.astype(np.float32)
    assert wrong.mean() < 0.1
    x, y = particles[0, wrong[0, 0], 0], particles[0, wrong[0, 0], 1]
    assert np.abs(y - (100.0 + x / 4.0)).max() < 4.0  # within the cloud's lesser sigma (UAV over the corner (40, 110))
