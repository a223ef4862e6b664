"""Intelligence-aware constrained batch MLE and its bounds (estimators/intelligence.py)
and 000's study (studies/oliva2021.py; Oliva, Farina, Setola 2021).

Constraint functions, their Jacobians and the augmented Lagrangian's derivatives are
checked against central finite differences; the bounds against 000 Table 3 and
hand-derived properties; the solver against noise-free bearings, feasibility and the
KKT conditions; the study against Table 2's definitions and its one robust finding
(constraints help without the APF direction).
"""

import json

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
    """000's sets on noisy bearings (8 runs, both geometries): every solution is feasible
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


def test_crlb_at_the_truth_matches_table_3():
    """000 Table 3, CRLB column: 7.713e5 for the APF geometry; ours 7.771e5 (bearings at
    k = 1..1800, the distance reading of Eq. 18).  The no-APF row prints the same 7.713e5,
    which we take for a copy: that geometry's bound is 3.705e7."""
    apf = oliva.bounds(oliva.GAMMA_APF, False)["crlb"]
    assert apf == pytest.approx(7.713e5, rel=0.02)
    assert oliva.bounds(0.0, False)["crlb"] == pytest.approx(3.705e7, rel=1e-3)


def test_constrained_crlb_properties_and_table_3():
    """Sec. 2.6 on one constraint by hand (C - C f f^T C / f^T C f); inactive and kink
    constraints drop out; the bound is below the unconstrained one and has zero variance
    along the active gradients.  At the truth: proposed 1.821e3 against the published
    1.873e3 (34 active, rank 4); without APF 5.68e3 against 1.454e3, as measured (the
    rank, 3, decides the number: docs/results/oliva2021.md)."""
    rng = np.random.default_rng(3)
    a = rng.normal(size=(6, 6))
    c = a @ a.T + np.eye(6)
    f = rng.normal(size=6)
    hand = c - np.outer(c @ f, c @ f) / (f @ c @ f)
    out = intel.constrained_crlb(c, np.stack([f, 3 * f, rng.normal(size=6), f]), [2.0, 0.5, -1.0, 0.0])
    assert out.active == 2 and out.rank == 1 and np.allclose(out.bound, hand)
    assert np.allclose(intel.constrained_crlb(c, f[None], [-1.0]).bound, c)
    prop = oliva.bounds(oliva.GAMMA_APF, True)
    assert (prop["active"], prop["rank"]) == (34, 4) and prop["crlb"] == pytest.approx(1.873e3, rel=0.05)
    noapf = oliva.bounds(0.0, True)
    assert noapf["rank"] == 3 and noapf["crlb"] == pytest.approx(5.677e3, rel=0.01)
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


def test_ownship_follows_eq_18():
    """From the origin; gamma = 0: x = vbar t, y = A sin(omega vbar t); gamma rotates it."""
    t = oliva.times()
    o0, o1 = oliva.ownship(0.0), oliva.ownship(0.749)
    assert np.allclose(o0[0], 0) and len(t) == 1801 and t[-1] == 3600
    assert np.allclose(o0[:, 0], 7.778 * t) and np.allclose(o0[:, 1], 5e3 * np.sin(2.5e-4 * 7.778 * t))
    rot = np.array([[np.cos(0.749), -np.sin(0.749)], [np.sin(0.749), np.cos(0.749)]])
    assert np.allclose(o1, o0 @ rot.T)


def test_errors_recompute_table_2():
    """Eq. (20)-(22) on 000 Table 2's printed parameters give its printed errors
    (proposed, average and best; no information, best), to 3%: the parameters are
    printed to four digits, and half a unit of the fourth digit of x0 (5 m of 30 km) moves
    a relative position error of 0.012 by up to 2%."""
    rows = [((3.040e4, 3.035e4, 7.912, 7.382, 2.652e-4, 2.598e-4), (0.01767, 0.07169, 3.713e-4)),
            ((3.026e4, 3.023e4, 8.070, 7.531, 1.835e-4, 1.821e-4), (0.01179, 0.04471, 2.586e-4)),
            ((3.028e4, 3.024e4, 8.045, 7.507, 1.989e-4, 1.969e-4), (0.01243, 0.04902, 2.789e-4))]
    for theta, published in rows:
        assert np.allclose(oliva.errors(np.array(theta)), published, rtol=0.03)


def test_constraints_help_without_the_apf_direction():
    """000 Sec. 3's finding that holds with a converged solver: in the no-APF geometry the
    constrained MLE beats the unconstrained one (same 30 noise draws): lower position
    RMSE and a smaller covariance norm (Table 3: 3.696e7 against 3.851e8).  Measured here:
    RMSE 3.52 km against 5.42 km, covariance 7.8e6 against 3.0e7 (100 runs: 1.0e7 against
    4.1e7).  The constraints trim the far tail rather than help every run: the paired
    difference of squared position errors has t = 2.3 over these 30 runs and favours the
    constrained estimate in 12 of them.  Not asserted: that the APF direction alone does not
    help; with a converged solver it does (docs/results/oliva2021.md)."""
    noise = _noise(30)
    rows = {name: oliva.run_scenario(name, noise) for name in ("no-information", "constrained-no-apf")}
    rmse = {n: np.sqrt(((np.array(r["theta"])[:, :2] - 3e4) ** 2).sum(1).mean()) for n, r in rows.items()}
    assert rmse["constrained-no-apf"] < rmse["no-information"], rmse
    assert rows["constrained-no-apf"]["cov"] < rows["no-information"]["cov"]
    assert rows["constrained-no-apf"]["feasible"] == 30


def test_global_stage_budget_and_polish():
    """Differential evolution with a small budget (30 generations of 90 members) stops far
    from the MLE, as 000's MIDACO rows do (objective hundreds above the local solver's;
    ``benchmarks/oliva2021.py --global``: 300 generations reach it); the local polish from
    there finds the local solver's minimum, with and without constraints (one minimum:
    every start we tried ends there, docs/results/oliva2021.md)."""
    noise, gens = _noise(2, 7), oliva.streams(7, 2)
    for gamma, tc, runs in ((oliva.GAMMA_APF, None, 2), (oliva.GAMMA_APF, TC, 1)):
        data = oliva.problem(gamma, noise[:runs])
        glob = oliva.global_solve(data, tc, [g[1] for g in gens[:runs]], maxiter=30 if tc is None else 15)
        loc = oliva.local_solve(data, tc)
        raw = batch.nll(data, glob["raw"][:, None])[:, 0]
        assert (raw > loc["nll"] + 10).all() and np.allclose(glob["nll"], loc["nll"], atol=1e-6)
        assert (glob["violation"] <= 1e-3).all()
    assert (glob["evaluations"] == 16 * 90).all()


def test_study_is_reproducible_and_run_r_does_not_depend_on_runs():
    a = oliva.study(3, SEED, scenarios=("proposed",))
    b = oliva.study(2, SEED, scenarios=("proposed",))
    assert a["scenarios"]["proposed"]["theta"][:2] == b["scenarios"]["proposed"]["theta"]
    assert a["scenarios"]["proposed"]["theta"] == oliva.study(3, SEED, scenarios=("proposed",))["scenarios"][
        "proposed"]["theta"]


def test_tma_reproduce_oliva2021_command(tmp_path, capsys):
    from uavsim.cli import main

    assert main(["tma", "reproduce", "oliva2021", "--runs", "3", "--out", str(tmp_path)]) == 0
    result = json.loads((tmp_path / "result.json").read_text())
    assert list(result["scenarios"]) == list(oliva.SCENARIOS) and result["solver"] == "local"
    assert (tmp_path / "tracks.png").stat().st_size > 10_000
    out = capsys.readouterr().out
    assert "proposed" in out and "7.713e+05" in out
    assert main(["tma", "reproduce", "oh2021", "--solver", "global", "--out", str(tmp_path)]) == 2
    assert "applies to oliva2021 only" in capsys.readouterr().err
    assert main(["tma", "reproduce", "oliva2021", "--generations", "5", "--out", str(tmp_path)]) == 2
    assert "--generations needs --solver global" in capsys.readouterr().err
