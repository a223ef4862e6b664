"""Intelligence-aware constrained batch MLE and its bounds (estimators/intelligence.py),
on the geometry and intelligence of [Oliva2021]'s study (studies/oliva2021.py, tested in
tests/test_oliva2021.py).

Constraint functions, their Jacobians and the augmented Lagrangian's derivatives are
checked against central finite differences; the bounds against hand-derived properties;
the solver against noise-free bearings, feasibility and the KKT conditions.
"""

import numpy as np
import pytest

from uavsim.estimators import batch
from uavsim.estimators import intelligence as intel
from uavsim.studies import oliva2021 as oliva

SEED = 2021


def _fd(f, x, h):
    """Central differences of ``f`` at ``x`` with steps ``h``: ``(..., n)``."""
    return np.stack([(f(x + e) - f(x - e)) / (2 * e.sum()) for e in np.diag(h)], -1)


H = np.array([1.0, 1.0, 1e-3, 1e-3, 1e-6, 1e-6])
TC = oliva.constraints()


def _noise(runs, seed=SEED):
    return np.stack([g[0].standard_normal(1800) for g in oliva.streams(seed, runs)])


def test_constraint_values_by_hand():
    """g = +-(|p - c|^2 - r^2) / (2 r): -r/2 at an inside disc's centre, 0 on a circle,
    +r/2 at an outside disc's centre (violated), and about the distance out nearby."""
    i = oliva.INTELLIGENCE
    hand = [-2.5e4, (1e8 + 1e8 - 4.5e4**2) / 9e4, -(9e8 + 9e8 - 6.25e8) / 5e4]
    assert np.allclose(i.values(np.array([1e4, 5e4])), hand)
    assert np.allclose(i.values(np.array([4e4, 8e4]))[2], 1.25e4)
    assert abs(i.values(np.array([1e4, 1e5]))[0]) < 1e-9
    assert i.values(np.array([1e4, 1e5 + 10.0]))[0] == pytest.approx(10.0, rel=1e-3)


def test_bad_input_is_refused():
    for bad in (lambda: intel.Disc((0.0, 0.0), 0.0), lambda: intel.Disc((0.0, np.nan), 1.0),
                lambda: intel.Intelligence(((0.0, 0.0, 1.0),)), lambda: intel.TrackConstraints(oliva.INTELLIGENCE,
                                                                                           np.zeros((5, 3, 6))),
                lambda: intel.TrackConstraints(intel.Intelligence(), TC.phi),
                lambda: intel.heading([0.0, 0.0])):
        with pytest.raises(ValueError):
            bad()
    data = oliva.problem(0.0, np.zeros((2, 1800)))
    for theta0 in (np.zeros((3, 6)), np.zeros((2, 4)), np.full((2, 6), np.nan)):
        with pytest.raises(ValueError, match="theta0"):
            intel.solve(data, theta0)


def test_track_constraints_and_jacobian_by_finite_differences():
    """TrackConstraints.values equals Intelligence.values at Q(k) theta; the Jacobian
    equals central differences (the values are quadratic: differences are exact up to
    rounding); the truth violates X1 at the last 34 samples only."""
    rng = np.random.default_rng(0)
    theta = oliva.TRUTH + rng.normal(0, 1, (3, 6)) * [3e3, 3e3, 2, 2, 1e-3, 1e-3]
    p = TC.positions(theta)
    assert np.allclose(TC.values(theta), oliva.INTELLIGENCE.values(p), rtol=1e-10, atol=1e-6)
    for th in theta:
        fd = _fd(TC.values, th, H)
        assert np.allclose(TC.jacobian(th), fd, rtol=1e-6, atol=1e-6 * np.abs(fd).max())
    g = TC.values(oliva.TRUTH)
    assert (g > 0).sum() == 34 and (g[:, 0] > 0).sum() == 34 and (g[-34:, 0] > 0).all()
    end = oliva.TRUTH[:2] + 3600 * oliva.TRUTH[2:4] - [1e4, 5e4]  # from X1's centre at t = 3600 s
    assert TC.violation(oliva.TRUTH) == pytest.approx(((end**2).sum() - 5e4**2) / 1e5, rel=1e-9)


def test_pseudo_linear_and_solve_return_the_truth_on_noise_free_bearings():
    """Noise-free bearings: the pseudo-linear equations hold exactly at the truth, and the
    MLE from a far start (5 km, 3 m/s off) is the truth, in both geometries: ``lam < 1e-12``
    is a Mahalanobis distance below 1.4e-6 standard deviations of the CRLB (the solver
    stops on a predicted decrease of 1e-8, so the last millimetres are not chased)."""
    for gamma in (0.0, oliva.GAMMA_APF):
        data = oliva.problem(gamma, np.zeros((1, 1800)))
        assert np.allclose(intel.pseudo_linear(data)[0], oliva.TRUTH, rtol=1e-8, atol=1e-9)
        res = intel.solve(data, (oliva.TRUTH + [5e3, -5e3, 3, -3, 1e-3, 0])[None])
        assert res.converged.all() and res.nll[0, 0] < 1e-12
        std = np.sqrt(np.diag(batch.crlb(TC.phi[1:], oliva.ownship(oliva.GAMMA_APF)[1:], oliva.TRUTH, np.radians(0.5))))
    assert res.nll[0, 0] < 1e-8 and (np.abs(res.theta[0, 0] - oliva.TRUTH) < 1e-3 * std).all()


def test_constrained_solve_returns_a_feasible_truth_and_is_inactive():
    """With X1 grown so that the truth is strictly inside every set, the constrained MLE
    of noise-free bearings from a start 2 km and 1 m/s off is the truth, and every
    multiplier is zero: ``lam`` below SLSQP's ftol, 1e-8, and within 1e-3 standard
    deviations (CRLB) of the truth."""
    grown = intel.Intelligence((intel.Disc((1e4, 5e4), 5.2e4), *oliva.INTELLIGENCE.inside[1:]),
                               oliva.INTELLIGENCE.outside)
    tc = intel.TrackConstraints(grown, TC.phi)
    assert tc.values(oliva.TRUTH).max() < -100
    data = oliva.problem(oliva.GAMMA_APF, np.zeros((1, 1800)))
    res = intel.solve(data, (oliva.TRUTH + [2e3, 0, 1, 0, 0, 0])[None], tc)
    assert res.converged.all() and res.violation.max() == 0 and np.abs(res.multipliers).max() < 1e-9
    std = np.sqrt(np.diag(batch.crlb(TC.phi[1:], oliva.ownship(oliva.GAMMA_APF)[1:], oliva.TRUTH, np.radians(0.5))))
    assert res.nll[0, 0] < 1e-8 and (np.abs(res.theta[0, 0] - oliva.TRUTH) < 1e-3 * std).all()


def test_constrained_solutions_are_feasible_kkt_points():
    """[Oliva2021]'s sets on noisy bearings (8 runs, both geometries): every solution is feasible
    to 1 mm (MIDACO's feasibility accuracy 0.001), costs at least the unconstrained MLE,
    and satisfies the KKT conditions: multipliers >= 0, zero where the constraint is
    slack by more than 1 m, and ``r = grad lam + sum y grad g = 0``, measured as the
    decrease of ``lam`` a Gauss-Newton step would still find, ``r^T F^-1 r / 2``: below
    1e-4 (the noise moves ``lam`` by about 3; SLSQP's ftol is 1e-8).  The unconstrained
    MLE is itself stationary: the same measure on ``grad lam`` below 1e-8."""
    for gamma in (0.0, oliva.GAMMA_APF):
        data = oliva.problem(gamma, _noise(8))
        unc = intel.solve(data, intel.pseudo_linear(data))
        res = intel.solve(data, unc.theta, TC)
        assert unc.converged.all() and res.converged.all() and res.violation.max() <= 1e-3
        assert (res.nll >= unc.nll - 1e-9).all() and (res.nll > unc.nll + 1e-3).any()
        y, g = res.multipliers[:, 0], TC.values(res.theta[:, 0])
        assert (y >= -1e-9).all() and (np.abs(y[g < -1.0]) < 1e-9).all() and (y > 0).any()
        for theta, mult, bound in ((res.theta, y, 1e-4), (unc.theta, 0 * y, 1e-8)):
            _, grad, fim = (a[:, 0] for a in batch.derivatives(data, theta))
            kkt = grad + np.einsum("rks,rksn->rn", mult, TC.jacobian(theta[:, 0]))
            decrement = 0.5 * np.einsum("ri,ri->r", kkt, np.linalg.solve(fim, kkt[..., None])[..., 0])
            assert (decrement < bound).all(), decrement


def test_constrained_crlb_properties():
    """Sec. 2.6 on one constraint by hand (C - C f f^T C / f^T C f); inactive and kink
    constraints drop out; the bound is below the unconstrained one and has zero variance
    along the active gradients.  Its values at the truth against [Oliva2021, Table 3]:
    tests/test_oliva2021.py."""
    rng = np.random.default_rng(3)
    a = rng.normal(size=(6, 6))
    c = a @ a.T + np.eye(6)
    f = rng.normal(size=6)
    hand = c - np.outer(c @ f, c @ f) / (f @ c @ f)
    out = intel.constrained_crlb(c, np.stack([f, 3 * f, rng.normal(size=6), f]), [2.0, 0.5, -1.0, 0.0])
    assert out.active == 2 and out.rank == 1 and np.allclose(out.bound, hand)
    assert np.allclose(intel.constrained_crlb(c, f[None], [-1.0]).bound, c)
    unc = batch.crlb(TC.phi[1:], oliva.ownship(oliva.GAMMA_APF)[1:], oliva.TRUTH, np.radians(0.5))
    full = intel.constrained_crlb(unc, TC.jacobian(oliva.TRUTH), TC.values(oliva.TRUTH))
    assert np.linalg.eigvalsh(unc - full.bound).min() > -1e-6 * np.linalg.norm(unc, 2)
    with pytest.raises(ValueError, match="gradients"):
        intel.constrained_crlb(c, f[None], [1.0, 2.0])


def test_apf_force_by_hand_and_the_published_direction():
    """f(0) = sum alpha_i x_i - sum beta_i y_i: with the text's weights the repulsion of
    Y1 (area 1.96e9 m^2) dominates: f ~ -area(Y1) y1, -2.034 rad from +x; the caption's
    weights give 1.311 rad.  Neither is the published 0.749."""
    i = oliva.INTELLIGENCE
    f = intel.apf_force(i)
    hand = sum(np.asarray(d.centre) / d.area for d in i.inside) - np.pi * 2.5e4**2 * np.array([4e4, 8e4])
    assert np.allclose(f, hand)
    text, caption = intel.heading(f), intel.heading(intel.apf_force(i, "caption"))
    assert text["from_x"] == pytest.approx(-2.0344, abs=1e-4) and caption["from_x"] == pytest.approx(1.3111, abs=1e-4)
    assert intel.heading([0.0, 1.0]) == {"from_x": pytest.approx(np.pi / 2), "from_y": 0.0}
    for h in (text, caption):
        assert all(abs(v - oliva.GAMMA_APF) > 0.2 for v in h.values())
    with pytest.raises(ValueError):
        intel.apf_force(i, "mass")
