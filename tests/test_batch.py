"""Batch maximum-likelihood TMA (estimators/batch.py) and [Oh2021]'s NR, PSO and NRPSO
(estimators/nrpso.py), on the geometry of its study (studies/oh2021.py, tested in
tests/test_oh2021.py).

Derivatives are checked against central finite differences and the CRLB against an
independent reference implementation; NR's matrix (Fisher, not the full Hessian) by
divergence counts (``estimators/nrpso.py``).
"""

import re
import warnings

import numpy as np
import pytest

from uavsim.estimators import api, batch, nrpso
from uavsim.studies import oh2021

SEED = 2021


def _geometry(order=1, k=40, runs=2, seed=0):
    """A weaving observer, ``runs`` noisy bearing sets of one target, candidates near it."""
    rng = np.random.default_rng(seed)
    t = np.arange(k) * 15.0
    phi = batch.polynomial_basis(t, order)
    obs = np.stack([300 * np.sin(t / 120), 4.0 * t], -1)
    truth = np.array([3000.0, 9000, -6, 2, 0.004, -0.003][:phi.shape[2]])
    d = phi @ truth - obs
    z = np.arctan2(d[:, 1], d[:, 0]) + rng.normal(0, 0.02, (runs, k))
    theta = truth + rng.normal(0, 1, (runs, 3, len(truth))) * np.array([200, 200, 1, 1, 0.002, 0.002])[:len(truth)]
    return phi, obs, truth, z, theta


def _fd(f, x, h):
    """Central differences of ``f`` (vector or scalar) at ``x`` with steps ``h``."""
    return np.stack([(f(x + e) - f(x - e)) / (2 * e.sum()) for e in np.diag(h)], -1)


@pytest.mark.parametrize("order", [1, 2])
def test_gradient_fisher_and_hessian_by_finite_differences(order):
    """M against differences of lam; F against J^T J / sigma^2 with J the differenced
    bearings (the Gauss-Newton matrix); the full Hessian against differences of M.  For
    constant velocity ([Oh2021]) and constant acceleration ([Oliva2021]'s six parameters)."""
    phi, obs, _, z, theta = _geometry(order)
    data = batch.prepare(phi, obs, z, 0.02)
    lam, grad, fim = batch.derivatives(data, theta)
    hess = batch.derivatives(data, theta, hessian=True)[2]
    h = np.array([1e-2, 1e-2, 1e-4, 1e-4, 1e-7, 1e-7])[:phi.shape[2]]
    for r in range(2):
        run = data.take([r])

        def lam_of(y, run=run):
            return batch.nll(run, y[None, None])[0, 0]

        def grad_of(y, run=run):
            return batch.derivatives(run, y[None, None])[1][0, 0]

        def bearing_of(y, run=run):  # h = z - e
            return -batch.residuals(run, y[None, None])[0, 0]

        for p in range(3):
            x = theta[r, p]
            np.testing.assert_allclose(grad[r, p], _fd(lam_of, x, h), rtol=1e-6)
            np.testing.assert_allclose(hess[r, p], _fd(grad_of, x, h), rtol=1e-5, atol=1e-6 * np.abs(hess[r, p]).max())
            jac = _fd(bearing_of, x, h)
            np.testing.assert_allclose(fim[r, p], jac.T @ jac / 0.02**2, rtol=1e-6, atol=1e-9 * np.abs(fim[r, p]).max())
            e = batch.residuals(run, x[None, None])[0, 0]
            assert lam[r, p] == pytest.approx(0.5 * np.sum(e**2) / 0.02**2, rel=1e-12)


def test_residuals_are_wrapped_and_the_bearing_is_from_x():
    """Bearing -pi + 0.01 (from +x): to a target due west (h = pi) the residual is
    -2 pi + 0.01, wrapped to 0.01; to one due north (h = pi / 2), pi / 2 + 0.01."""
    phi = batch.polynomial_basis([0.0])
    data = batch.prepare(phi, [[0.0, 0.0]], [-np.pi + 0.01], 0.1)
    theta = np.array([[[-1000.0, 0.0, 0.0, 0.0], [0.0, 1000.0, 0.0, 0.0]]])  # west; north (h = pi/2)
    np.testing.assert_allclose(batch.residuals(data, theta)[0, :, 0], [0.01, -np.pi + 0.01 - np.pi / 2 + 2 * np.pi])


def test_polynomial_basis():
    """[Oliva2021, Eq. (12)]: Q(k) = [I, kT I, k^2 T^2 / 2 I]; [Oh2021, Eq. (2)] for order 1."""
    phi = batch.polynomial_basis([10.0, 12.0], order=2)
    np.testing.assert_allclose(phi[1], [[1, 0, 2, 0, 2, 0], [0, 1, 0, 2, 0, 2]])
    np.testing.assert_allclose(batch.polynomial_basis([0.0, 3.0])[1], [[1, 0, 3, 0], [0, 1, 0, 3]])
    with pytest.raises(ValueError, match="times"):
        batch.polynomial_basis([[0.0, 1.0]])


def test_bad_input_is_refused():
    phi = batch.polynomial_basis(np.arange(5.0))
    obs = np.zeros((5, 2))
    with pytest.raises(ValueError, match="sigma must be positive"):
        batch.prepare(phi, obs, np.zeros(5), 0.0)
    with pytest.raises(ValueError, match="bearings has non-finite"):
        batch.prepare(phi, obs, [0, 0, np.nan, 0, 0], 0.1)
    with pytest.raises(ValueError, match="observer positions"):
        batch.prepare(phi, np.zeros((4, 2)), np.zeros(5), 0.1)
    with pytest.raises(ValueError, match="theta must be"):
        batch.nll(batch.prepare(phi, obs, np.zeros(5), 0.1), np.zeros((1, 4)))
    with pytest.raises(ValueError, match="sigma must be a positive"):
        nrpso.BatchTMA(sigma=-1.0)
    with pytest.raises(ValueError, match="method must be"):
        nrpso.BatchTMA(sigma=0.01, method="ga")


def test_blocks_and_float32_agree_with_one_float64_pass():
    """The evaluator's cache-sized blocks do not change the numbers; float32 changes lam by
    about 1e-7 relative and the gradient by about 1e-6 of its scale."""
    phi, obs, _, z, theta = _geometry(k=200)
    data = batch.prepare(phi, obs, z, 0.02)
    ref = batch.Evaluator(data, block=10**9).derivatives(theta)
    for block in (1, 200, 700):
        for a, b in zip(batch.Evaluator(data, block=block).derivatives(theta), ref):
            np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * np.abs(b).max())
    lam32, grad32, _ = batch.Evaluator(data.astype(np.float32)).derivatives(theta)
    np.testing.assert_allclose(lam32, ref[0], rtol=2e-6)
    assert np.abs(grad32 - ref[1]).max() < 1e-5 * np.abs(ref[1]).max()


def test_cholesky_solve_and_its_failures():
    rng = np.random.default_rng(1)
    a = rng.normal(size=(3, 5, 4, 6))
    a = a @ np.swapaxes(a, -1, -2) + 0.1 * np.eye(4)
    b = rng.normal(size=(3, 5, 4))
    x, det, ok = batch.cholesky_solve(a, b)
    np.testing.assert_allclose(x, np.linalg.solve(a, b[..., None])[..., 0], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(det, np.linalg.det(a), rtol=1e-9)
    assert ok.all()
    a[0, 0], a[0, 1, 3, 3] = -np.eye(4), np.nan
    x, det, ok = batch.cholesky_solve(a, b)
    assert not ok[0, :2].any() and ok[0, 2:].all() and (x[0, :2] == 0).all() and (det[0, :2] == 0).all()


def test_crlb_matches_the_reference_and_finite_differences():
    """The independent reference implementation's results: CRLB position RMSE of target 2 at K = 600:
    273 m (0.1 deg), 1364 m (0.5 deg), 5183 m (1.9 deg); det F at the truth 1.7e3, 4.4e-3,
    1.0e-7 (SI).  The bound scales with sigma exactly."""
    t = oh2021.times(600)
    obs, x0 = oh2021.observer(t), np.array(oh2021.TARGETS[2])
    phi = batch.polynomial_basis(t)
    for sd, pos, det in ((0.1, 273, 1.7e3), (0.5, 1364, 4.4e-3), (1.9, 5183, 1.0e-7)):
        bound = batch.crlb(phi, obs, x0, np.radians(sd))
        assert np.sqrt(bound[0, 0] + bound[1, 1]) == pytest.approx(pos, abs=0.5)
        assert 1 / np.linalg.det(bound) == pytest.approx(det, rel=0.05)
    jac = _fd(lambda y: np.arctan2(*(phi @ y - obs).T[::-1]), x0, np.array([1e-2, 1e-2, 1e-4, 1e-4]))
    np.testing.assert_allclose(batch.crlb(phi, obs, x0, 0.01), np.linalg.inv(jac.T @ jac / 1e-4), rtol=1e-5)


def test_newton_converges_in_a_few_steps_on_noise_free_bearings():
    """From 300 m and 1 m/s off the truth, no noise: the Gauss-Newton iterates reach the
    truth (lam = 0) quadratically, in at most 6 steps, for every target."""
    t = oh2021.times(600)
    for target in (1, 2, 3):
        prob = nrpso.problem(t, oh2021.bearings(target, t), oh2021.observer(t), np.radians(0.5))
        x0 = np.array(oh2021.TARGETS[target])
        res = batch.gauss_newton(prob.data, (x0 + [300, -300, 1, -1])[None])
        assert res.converged[0] and not res.degenerate[0] and res.n_iter[0] <= 6
        np.testing.assert_allclose(res.theta[0], x0, atol=1e-6)


def test_singular_fisher_matrix_is_reported_not_nan():
    """A still observer and a target moving straight away: every bearing is 0, the range
    is unobservable and F is singular.  The run stops at its start, flagged degenerate."""
    t = np.arange(20.0)
    data = batch.prepare(batch.polynomial_basis(t), np.zeros((20, 2)), np.zeros(20), 0.01)
    res = batch.gauss_newton(data, np.array([[1000.0, 0, 5, 0]]))
    assert res.degenerate[0] and not res.converged[0] and res.n_iter[0] == 0
    np.testing.assert_array_equal(res.theta[0], [1000.0, 0, 5, 0])


def test_bearings_from_north_are_converted_at_the_edge():
    """[Oh2021, Eq. (3)]: theta = atan2(dx, dy), clockwise from north.  problem() turns them into
    batch's h = pi/2 - theta once: at the truth every residual vanishes, and the data equal
    those prepared from +x bearings atan2(dy, dx).  Fed as if they were from +x, the
    bearings put the truth off by far more than the noise."""
    t = oh2021.times(100)
    obs, north = oh2021.observer(t), oh2021.bearings(1, t)
    prob = nrpso.problem(t, north, obs, 0.01)
    x0 = np.array(oh2021.TARGETS[1])
    assert np.abs(batch.residuals(prob.data, x0[None, None])).max() < 1e-12
    d = oh2021.truth(1, t)[:, :2] - obs
    direct = batch.prepare(batch.polynomial_basis(t), obs, np.arctan2(d[:, 1], d[:, 0]), 0.01)
    np.testing.assert_allclose(prob.data.design, direct.design, atol=1e-9)
    wrong = batch.prepare(batch.polynomial_basis(t), obs, north, 0.01)
    assert np.abs(batch.residuals(wrong, x0[None, None])).min() > 0.3
    fit = nrpso.BatchTMA(np.radians(0.1), method="nr", rng=np.random.default_rng(0)).fit(t, north, obs)
    np.testing.assert_allclose(fit.x_, x0, atol=1e-6)
    assert fit.converged_ and fit.x_.shape == (4,) and fit.cov_.shape == (4, 4)


def test_search_area_sampling_and_projection():
    """Table 2: draws lie in the sector (range <= 15 km, bearing within 3 sigma) with speed
    <= 15 m/s; projection leaves inside points exactly and maps outside ones onto the
    boundary."""
    win = nrpso.SearchArea().window([[100.0, -50.0]], [0.3], np.radians(1.0))
    x = win.sample(np.random.default_rng(2).random((1, 5000, 4)))
    assert win.contains(x).all()
    np.testing.assert_array_equal(win.project(x), x)
    far = np.array([[[100 + 30e3 * np.cos(1.0), -50 + 30e3 * np.sin(1.0), 40.0, 0.0]]])
    p = win.project(far)
    assert win.contains(p).all()
    rel = p[0, 0, :2] - [100, -50]
    assert np.hypot(*rel) == pytest.approx(15e3)
    assert np.arctan2(rel[1], rel[0]) == pytest.approx(0.3 + 3 * np.radians(1))
    np.testing.assert_allclose(p[0, 0, 2:], [15.0, 0.0])


def _small_problem(target=2, sigma_deg=1.9, runs=4, scans=200, seed=SEED):
    t = oh2021.times(scans)
    gens = oh2021.streams(seed, runs)
    sig = np.radians(sigma_deg)
    z = oh2021.bearings(target, t) + sig * np.stack([g[0].standard_normal(scans) for g in gens])
    return nrpso.problem(t, z, oh2021.observer(t), sig), gens


@pytest.mark.parametrize("method", ["pso", "nrpso"])
def test_particles_stay_inside_the_search_area(method, monkeypatch):
    """[Oh2021, Sec. 4]: "PSO only considers the solution inside the search area".  Every
    position the swarm evaluates (400 particles x 50 iterations) is in the area."""
    prob, gens = _small_problem(sigma_deg=0.3)
    seen = []
    for name in ("nll", "derivatives"):
        orig = getattr(batch.Evaluator, name)

        def spy(self, theta, *a, _orig=orig, **k):
            if theta.shape[1] > 1:
                seen.append(np.array(theta))
            return _orig(self, theta, *a, **k)

        monkeypatch.setattr(batch.Evaluator, name, spy)
    res = getattr(nrpso, method)(prob, [g[2] for g in gens])
    assert len(seen) == 51 and all(prob.window.contains(x).all() for x in seen)
    assert prob.window.contains(res.theta[:, None]).all()
    if method == "nrpso":
        assert (res.newton_share > 0).all()


def test_screening_finds_the_same_best_candidate():
    """The exact screen of best_candidate against evaluating all 10 000 candidates."""
    for sigma_deg in (0.1, 1.9):
        prob, _ = _small_problem(sigma_deg=sigma_deg, runs=3, scans=600)
        data = prob.data.astype(np.float32)
        a = nrpso.best_candidate(data, prob.window, np.random.default_rng(5), screen=1)
        b = nrpso.best_candidate(data, prob.window, np.random.default_rng(5), screen=8)
        np.testing.assert_array_equal(a[0], b[0])


def test_estimator_is_deterministic_and_batched():
    """Same settings and seed, same result; a batch of runs equals the runs one by one when
    each has its own generator."""
    t = oh2021.times(100)
    obs = oh2021.observer(t)
    rng = np.random.default_rng(SEED)
    bearings = oh2021.bearings(2, t) + np.radians(1.9) * rng.standard_normal((3, 100))

    def fit(z, rngs):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", api.ConvergenceWarning)  # 10 iterations of 50 particles: tested apart
            return nrpso.BatchTMA(np.radians(1.9), method="nrpso", n_particles=50, n_iter=10, rng=rngs).fit(t, z, obs)

    fits = [fit(bearings, [np.random.default_rng(r) for r in range(3)]) for _ in range(2)]
    np.testing.assert_array_equal(fits[0].x_, fits[1].x_)
    one = fit(bearings[2], np.random.default_rng(2))
    np.testing.assert_allclose(one.x_, fits[0].x_[2], rtol=1e-12)
    assert fits[0].x_.shape == (3, 4) and (fits[0].n_iter_ >= 10).all() and one.cov_.shape == (4, 4)  # + polish


def _nr(target, sigma_deg, runs, **kw):
    """NR on ``runs`` noisy bearing sets of one target at K = 600: the study's metrics and the result."""
    prob, gens = _small_problem(target, sigma_deg, runs, 600)
    res = nrpso.newton_raphson(prob, [g[1] for g in gens], **kw)
    m = oh2021.metrics(res.theta, np.array(oh2021.TARGETS[target]), oh2021.observer([0.0])[0])
    return m, res


def test_full_hessian_newton_diverges_where_gauss_newton_does_not():
    """Which matrix is Oh2021's dM/dX: target 2 at 0.1 deg, the reference implementation measured
    divergence 1% with the Fisher (Gauss-Newton) matrix and 79% with the full Hessian from
    the same 10 000-candidate start.  The paper reports no divergence at small noise, so it
    used the former.  100 runs: GN at most 5%, the full Hessian at least 50%.
    Measured: 0% and 75%."""
    gn, _ = _nr(2, 0.1, 100)
    full, _ = _nr(2, 0.1, 100, hessian=True)
    assert gn["diverged_pct"] <= 5 and full["diverged_pct"] >= 50, (gn, full)


def _runs(target, sigma_deg, runs, seed=7, scans=100):
    t = oh2021.times(scans)
    rng = np.random.default_rng(seed)
    z = oh2021.bearings(target, t) + np.radians(sigma_deg) * rng.standard_normal((runs, scans))
    return t, z, oh2021.observer(t), np.array(oh2021.TARGETS[target])


def _fit(method, sigma_deg, data, **kw):
    """BatchTMA on ``data`` with one generator per run, its warnings silenced (tested apart)."""
    t, z, obs, _ = data
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return nrpso.BatchTMA(np.radians(sigma_deg), method=method, rng=[np.random.default_rng(k) for k in
                                                                          range(len(z))], **kw).fit(t, z, obs)


def test_damped_newton_never_diverges_silently():
    """Weak geometry ([Oh2021] target 2, 1.9 deg, 100 scans, 300 runs): the paper's
    undamped NR sends runs beyond 1e9 m (measured: 1173 of 2000); the damped one
    (a line search: lam never rises) may still find the range unobservable (the
    likelihood rising towards infinite range), but then says so: every run beyond 1e9 m
    has ``converged_`` False or ``range_unobservable_`` True, and a ConvergenceWarning
    names the count (measured on 2000 runs: 0 silent)."""
    data = _runs(2, 1.9, 300)
    undamped = _fit("nr", 1.9, data, damped=False)
    err = np.hypot(*(undamped.x_[:, :2] - data[3][:2]).T)
    assert (err > 1e9).sum() >= 30  # the control: the paper's step diverges
    with pytest.warns(api.ConvergenceWarning) as said:
        damped = nrpso.BatchTMA(np.radians(1.9), method="nr", rng=[np.random.default_rng(k) for k in range(300)]
                                ).fit(*data[:3])
    said = [str(w.message) for w in said]
    assert any(re.match(r"nr: \d+ of 300 runs did not converge", m) for m in said), said
    assert any(re.match(r"nr: in \d+ of 300 runs the bearings do not fix the range", m) for m in said), said
    err = np.hypot(*(damped.x_[:, :2] - data[3][:2]).T)
    silent = (err > 1e9) & damped.converged_ & ~damped.range_unobservable_
    assert silent.sum() == 0 and damped.converged_.mean() > undamped.converged_.mean()


def test_polished_swarms_reach_the_maximum_likelihood():
    """PSO and NRPSO polished by the damped Gauss-Newton end where damped NR ends (the ML:
    the same nll to 1e-6 where both converge) and ``converged_`` means it: strong
    geometry ([Oh2021] target 1, 1 deg): every run converged (unpolished, the paper's
    swarm converges in none and stops above the ML)."""
    data = _runs(1, 1.0, 100)
    nr = _fit("nr", 1.0, data)
    for method in ("pso", "nrpso"):
        raw = _fit(method, 1.0, data, polish=False)
        pol = _fit(method, 1.0, data)
        both = nr.converged_ & pol.converged_
        assert pol.converged_.all() and not raw.converged_.any()
        np.testing.assert_allclose(pol.nll_[both], nr.nll_[both], rtol=1e-6)
        assert (raw.nll_ > pol.nll_ - 1e-9).all() and (raw.nll_ > pol.nll_ + 1e-3).mean() > 0.5


def test_a_search_area_that_bounds_the_swarm_is_said():
    """The area is a prior for the swarm: a target moving at 8 m/s searched with speeds up
    to 2 m/s ends at the area's speed limit in some runs (within 2% of it), and a
    SearchAreaWarning says so; the default area (15 m/s) says nothing."""
    t, z, obs, truth = _runs(1, 1.0, 20)
    assert np.hypot(*truth[2:]) == 8.0

    def said(area):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            nrpso.BatchTMA(np.radians(1.0), method="pso", area=area, polish=False,
                           rng=[np.random.default_rng(k) for k in range(20)]).fit(t, z, obs)
        return [str(w.message) for w in caught if w.category is api.SearchAreaWarning]

    slow = said(nrpso.SearchArea(speed_max=2.0))
    assert len(slow) == 1 and re.match(r"pso: in \d+ of 20 runs the swarm's best lies at the boundary", slow[0]), slow
    assert said(nrpso.SearchArea()) == []
