"""The study of [Li2022] Sec. 5 (Tables 5, 7, 9; Figs. 4-15).

The study runs with the paper's M0 = 1000 runs (seed 2021, about 6 s for the three
scenarios).  Monte-Carlo spread at that size: the relative standard error of a
time-averaged RMSE is 0.4-2.0% (per-run time-averaged squared errors); every
"constrained < unconstrained" and "PL-MMSE best" comparison has a paired t-statistic of
10 or more (the weakest, PL-MMSE < BC-PLKF on the line, t = 10.0), so the tests ask t > 5.
Published numbers are checked at 10% (5-10 standard errors) where we reach them; where we
do not, the measured ratio is asserted to 5% (3-5 standard errors) and the docstring says why.

What these comparisons are not: evidence about the bearings.  At the tables' noise
(rho = 7) every row of Tables 5, 7 and 9 is above its no-update control (the prior
predicted and constrained as the row is; ``tests/test_controls.py``), so a row that
matches its published number reproduces the paper's arithmetic, and "constrained beats
unconstrained" holds for dead reckoning too.  The bearings buy a lower error on the line
only at a tenth of the unit noise (47.5%).
"""

import json

import numpy as np
import pytest

from uavsim.studies import li2022 as L

RUNS, SEED = 1000, 2021
BASES = ("PL-MMSE", "PLKF", "BC-PLKF", "IVKF")


def test_scenarios_as_described():
    """Sec. 5.2-5.3: observer legs, exact line and circle, x_1, P_{1|1} as the initial
    mixture's covariance, Q through D, and the tables' sigma_theta labels as a units slip:
    label^2 = rho^2 R_bar 180 / pi (Tables 4, 6, 8 against R1, R2)."""
    line, slow, fast = (L.scenario(n) for n in L.SCENARIOS)
    np.testing.assert_allclose(line.observer[[0, 40, 80, 120, 160]], L.WAYPOINTS[:5])
    np.testing.assert_allclose(line.observer[199], L.WAYPOINTS[4] + 39 / 40 * (L.WAYPOINTS[5] - L.WAYPOINTS[4]))
    np.testing.assert_allclose(line.truth[0], [0, 0, 6 * np.sqrt(2), 6 * np.sqrt(2)])
    np.testing.assert_allclose(line.truth[:, [0, 2]], line.truth[:, [1, 3]])  # G x = 0, Eq. (72)-(73)
    for sc, v in ((slow, 1e-4), (fast, 0.2)):
        rel = sc.truth[:, :2] - [100, 0]
        np.testing.assert_allclose(sc.truth[0], [200, 0, 0, v])
        np.testing.assert_allclose(np.linalg.norm(rel, axis=1), 100, rtol=1e-14)
        np.testing.assert_allclose(np.einsum("ki,ki->k", rel, sc.truth[:, 2:]), 0, atol=1e-12)
    for sc, std_deg in ((line, 52.9), (slow, 5.30e-4), (fast, 16.76)):
        np.testing.assert_allclose(sc.initial.cov, sc.p0, rtol=1e-12)
        r_bar = sc.bearing.cov[0, 0]
        assert sc.label_deg_per_rho**2 == pytest.approx(r_bar * 180 / np.pi, rel=4e-3)  # line: 0.0174 vs pi/180
        assert np.degrees(7 * np.sqrt(r_bar)) == pytest.approx(std_deg, rel=2e-3)
    assert line.q[2, 2] == pytest.approx(0.1**2 * 0.198)


def test_metrics_by_hand():
    """Eq. (64)-(71) with first = 2 on two runs, three scans: errors (pos) (1, 0) and (-1, 0)
    at every scan (RMSE 1, BNorm 0); velocity errors (0, 2) in both runs from scan 2 on."""
    truth = np.zeros((3, 4))
    est = np.zeros((2, 3, 4))
    est[0, :, 0], est[1, :, 0] = 1.0, -1.0
    est[:, 1:, 3] = 2.0
    m = L.metrics(est, truth, first=2)
    np.testing.assert_allclose(m["rmse_pos"], 1.0)
    np.testing.assert_allclose(m["bnorm_pos"], 0.0)
    np.testing.assert_allclose(m["bnorm_vel"], [0, 2, 2])
    assert (m["rmse_pos_avg"], m["bnorm_vel_avg"], m["rmse_vel_avg"]) == (1.0, 2.0, 2.0)


def test_run_r_does_not_depend_on_the_number_of_runs():
    sc = L.scenario("li2022-line")
    x5, n5 = L.draw_runs(sc, 5, 7)
    x3, n3 = L.draw_runs(sc, 3, 7)
    np.testing.assert_array_equal(x5[:3], x3)
    np.testing.assert_array_equal(n5[:3], n3)


@pytest.fixture(scope="module")
def study():
    """Per scenario: the 12 rows' time averages and per-run time-averaged squared errors."""
    out = {}
    for name in L.SCENARIOS:
        sc = L.scenario(name)
        x0, noise = L.draw_runs(sc, RUNS, SEED)
        rows = {}
        for label, (est, degenerate, _) in L.run_rows(sc, x0, noise, L.RHO).items():
            err = est[:, L.L0 - 1:] - sc.truth[L.L0 - 1:]
            rows[label] = {**{k: v for k, v in L.metrics(est, sc.truth).items() if k.endswith("_avg")},
                           "degenerate": degenerate, "finite": bool(np.isfinite(est).all()),
                           "pos_runs": np.sum(err[..., :2] ** 2, -1).mean(1),
                           "vel_runs": np.sum(err[..., 2:] ** 2, -1).mean(1),
                           "published": [v * s for v, s in zip(sc.published[label], sc.unit_scale)]}
        out[name] = (sc, rows)
    return out


def ratio(study, name, label, metric=0):
    row = study[name][1][label]
    return row[L.METRICS[metric] + "_avg"] / row["published"][metric]


def paired_t(study, name, better, worse, part="pos"):
    d = study[name][1][worse][f"{part}_runs"] - study[name][1][better][f"{part}_runs"]
    return d.mean() / d.std(ddof=1) * np.sqrt(len(d))


@pytest.mark.parametrize("name", L.SCENARIOS)
def test_constrained_beats_unconstrained_for_every_filter(study, name):
    """Sec. 5.3 (Tables 5, 7, 9; Figs. 5, 9, 13): every constrained row below its
    unconstrained filter, position and velocity, paired t > 5 over the 1000 runs.

    Not informative about the bearings: the no-update controls order the same way
    (constrained dead reckoning beats unconstrained; module docstring)."""
    sc, _ = study[name]
    for base in BASES:
        for suffix in sc.variants:
            for part in ("pos", "vel"):
                assert paired_t(study, name, base + suffix, base, part) > 5, (base + suffix, part)


def test_pl_mmse_is_the_best_unconstrained_filter_on_the_line(study):
    """Table 5 / Fig. 4: PL-MMSE below PLKF, BC-PLKF and IVKF (t = 134, 10, 24), and
    PL-MMSE-C the best constrained row (Figs. 6-7).

    Not informative about the bearings: at rho = 7 every row is above its no-update control
    (module docstring; docs/results/li2022.md), so this checks the paper's arithmetic."""
    for other in BASES[1:]:
        assert paired_t(study, "li2022-line", "PL-MMSE", other) > 5
    rows = study["li2022-line"][1]
    constrained = [k for k in rows if "-C(" in k]
    assert min(constrained, key=lambda k: rows[k]["rmse_pos_avg"]).startswith("PL-MMSE-C")


def test_arc_slow_within_ten_percent_of_table7(study):
    """Table 7: every row's RMSEpos within 10% (measured 0.97-1.03), and RMSEvel of PLKF,
    BC-PLKF, IVKF and their -L/-S rows (0.99-1.01).  Final scan (Fig. 9): PL-MMSE
    2.96e-4 m / 2.02e-5 m/s against 3.099e-4 / 2.053e-5, within 10% (curves in result.json).

    Not reached: the PL-MMSE rows' RMSEvel (ratio 1.12; -L/-S 1.17).  With this tiny noise
    (std 9.2e-6 rad) c1 = 1 - 4e-11 and PL-MMSE is the PLKF to 1e-5 (asserted): the
    published 11% velocity advantage of PL-MMSE over PLKF cannot come from Table 1's
    equations.  Doubling PL-MMSE's R_k (docs/results/li2022.md, a fit) gives 0.94.

    Not informative about the bearings: at rho = 7 every row is above its no-update control
    (module docstring; docs/results/li2022.md), so this checks the paper's arithmetic."""
    rows = study["li2022-arc-slow"][1]
    for label in rows:
        assert 0.9 < ratio(study, "li2022-arc-slow", label, 0) < 1.1, label
        if not label.startswith("PL-MMSE"):
            assert 0.9 < ratio(study, "li2022-arc-slow", label, 1) < 1.1, label
    assert rows["PL-MMSE"]["rmse_vel_avg"] == pytest.approx(rows["PLKF"]["rmse_vel_avg"], rel=1e-5)
    assert ratio(study, "li2022-arc-slow", "PL-MMSE", 1) == pytest.approx(1.12, rel=0.05)
    assert ratio(study, "li2022-arc-slow", "PL-MMSE-L", 1) == pytest.approx(1.17, rel=0.05)


def test_arc_fast_baselines_within_ten_percent_of_table9(study):
    """Table 9: PLKF, BC-PLKF, IVKF RMSEpos and RMSEvel within 10% (measured 0.93-0.97); their
    -L/-S rows at 0.90-0.92.

    Not reached: the PL-MMSE rows are 32% (L/S 47%) above the published values.  Our
    PL-MMSE is no better than BC-PLKF here (0.295 m against 0.298); the published one is 30%
    better.  R_k doubled in PL-MMSE alone gives 0.99 (docs/results/li2022.md): the paper's PL-MMSE weighs
    the bearings about half as much as Eq. (19) as derived says.

    Not informative about the bearings: at rho = 7 every row is above its no-update control
    (module docstring; docs/results/li2022.md), so this checks the paper's arithmetic."""
    for label in ("PLKF", "BC-PLKF", "IVKF"):
        for metric in (0, 1):
            assert 0.9 < ratio(study, "li2022-arc-fast", label, metric) < 1.1, (label, metric)
        for suffix in ("-L", "-S"):
            assert ratio(study, "li2022-arc-fast", label + suffix, 0) == pytest.approx(0.905, rel=0.05)
    assert ratio(study, "li2022-arc-fast", "PL-MMSE", 0) == pytest.approx(1.32, rel=0.05)
    assert ratio(study, "li2022-arc-fast", "PL-MMSE-S", 0) == pytest.approx(1.47, rel=0.05)


def test_line_as_measured(study):
    """Table 5: PL-MMSE-C (both W) within 10% (0.94), PL-MMSE 1.09.

    Not reached: the baselines are 21-38% better than published (PLKF 18.7 m against 27.1).
    Their only noise parameter is the pseudo-linear noise's second moment: with E e^2 for
    E sin^2 e (the paper does not say) PLKF drops to 9.2 m and BC-PLKF rises to 9.3 m
    (docs/results/li2022.md), neither near the table; what makes the published baselines more biased is
    not found.

    Not informative about the bearings: at rho = 7 every row is above its no-update control
    (module docstring; docs/results/li2022.md), so this checks the paper's arithmetic."""
    assert ratio(study, "li2022-line", "PL-MMSE-C(W=I)") == pytest.approx(0.94, abs=0.05)
    assert ratio(study, "li2022-line", "PL-MMSE-C(W=P^-1)") == pytest.approx(0.94, abs=0.05)
    assert ratio(study, "li2022-line", "PL-MMSE") == pytest.approx(1.09, rel=0.05)
    for label in ("PLKF", "BC-PLKF", "IVKF"):
        assert 0.6 < ratio(study, "li2022-line", label) < 0.85, label


def test_w_identity_and_w_inverse_p_agree_for_pl_mmse_on_the_line(study):
    """Table 5 prints identical PL-MMSE-C rows for both W: ours agree within 0.5%."""
    rows = study["li2022-line"][1]
    assert rows["PL-MMSE-C(W=P^-1)"]["rmse_pos_avg"] == pytest.approx(rows["PL-MMSE-C(W=I)"]["rmse_pos_avg"], rel=5e-3)


def test_linear_and_second_order_approximations(study):
    """The circle: L leaves a radial error (d - R)^2 / (2 d).  Slow arc: L and S agree to
    1e-15 relative (published L better than S on BNormvel, 1.590 against 1.708e-6: not
    reproduced; L and S positions differ by 3e-9 m at most and the velocity step is the
    same, so no 7% difference can come from them).  Fast arc: S below L at the 1e-6 m scale
    for PL-MMSE (4e-7 m), as the text on Table 9 says."""
    slow, fast = study["li2022-arc-slow"][1], study["li2022-arc-fast"][1]
    for base in BASES:
        assert slow[base + "-S"]["rmse_pos_avg"] == pytest.approx(slow[base + "-L"]["rmse_pos_avg"], rel=1e-12)
        assert slow[base + "-S"]["bnorm_vel_avg"] == pytest.approx(slow[base + "-L"]["bnorm_vel_avg"], rel=1e-6)
    gap = fast["PL-MMSE-L"]["rmse_pos_avg"] - fast["PL-MMSE-S"]["rmse_pos_avg"]
    assert 0 < gap < 1e-5


def test_bias_norms_sit_at_the_monte_carlo_floor(study):
    """Eq. (65), (69): for an unbiased filter BNorm is about 0.886 RMSE / sqrt(M0), noise not
    bias.  On the slow arc ours are at 0.9x that floor; the published ones are at 5.5-5.8x
    (PL-MMSE 3.528e-5 m against a floor of 6.4e-6 m), as if from about 30 independent runs or
    with a common error: the published BNorms of the unbiased rows are not reproducible."""
    rows = study["li2022-arc-slow"][1]
    for base in BASES:
        floor = 0.886 * rows[base]["rmse_pos_avg"] / np.sqrt(RUNS)
        assert 0.6 < rows[base]["bnorm_pos_avg"] / floor < 1.5
        assert rows[base]["published"][2] / floor > 4


def test_every_row_finite_and_never_degenerate(study):
    for _, rows in study.values():
        for label, row in rows.items():
            assert row["finite"] and row["degenerate"] == 0, label


def test_noise_sweeps_as_measured():
    """Figs. 4, 8, 12 at 300 runs (relative standard error 2.5%):
    Fig. 8 prose, PL-MMSE RMSEpos 2.526e-4 m (presumably at rho = 10): ours within 10%.
    Fig. 4, PL-MMSE "stable at 2.5 m" at large noise: ours within 10% at rho = 10.
    Fig. 12, V = 0.2: errors fall as the noise rises (the paper: "basically unchanged and
    slightly decrease"); ours fall by a third from rho = 1 to 3.  Its prose values at rho = 3
    (PL-MMSE 0.3346 m, PL-MMSE-S 0.2954 m) are not reached: ours 0.47 and 0.44, the PL-MMSE
    gap of Table 9 again."""
    def rmse(name, rho, label):
        sc = L.scenario(name)
        x0, noise = L.draw_runs(sc, 300, SEED)
        rows = L.run_rows(sc, x0, noise, rho)
        return {lab: L.metrics(rows[lab][0], sc.truth)["rmse_pos_avg"] for lab in label}

    assert rmse("li2022-arc-slow", 10.0, ["PL-MMSE"])["PL-MMSE"] == pytest.approx(2.526e-4, rel=0.1)
    assert rmse("li2022-line", 10.0, ["PL-MMSE"])["PL-MMSE"] == pytest.approx(2.5, rel=0.1)
    one, three = (rmse("li2022-arc-fast", rho, ["PL-MMSE", "PL-MMSE-S"]) for rho in (1.0, 3.0))
    assert three["PL-MMSE"] < 0.9 * one["PL-MMSE"]
    assert three["PL-MMSE"] == pytest.approx(0.47, rel=0.05)
    assert three["PL-MMSE-S"] == pytest.approx(0.44, rel=0.05)


def test_feedback_reading_changes_only_the_constrained_rows():
    """Reading(feedback=True): the unconstrained rows are the same runs; the constrained rows
    come from filters fed their projected estimates."""
    sc = L.scenario("li2022-line")
    x0, noise = L.draw_runs(sc, 10, 1)
    plain, fed = (L.run_rows(sc, x0, noise, 7.0, L.Reading(feedback=f)) for f in (False, True))
    np.testing.assert_array_equal(plain["PL-MMSE"][0], fed["PL-MMSE"][0])
    assert np.abs(plain["PL-MMSE-C(W=I)"][0] - fed["PL-MMSE-C(W=I)"][0]).max() > 1e-6
    np.testing.assert_allclose(fed["PL-MMSE-C(W=I)"][0][..., 0], fed["PL-MMSE-C(W=I)"][0][..., 1], atol=1e-12)


def test_tma_reproduce_li2022_command(tmp_path, capsys):
    from uavsim.cli import main

    out = tmp_path / "slow"
    assert main(["tma", "reproduce", "li2022-arc-slow", "--runs", "10", "--seed", "3", "--out", str(out),
                 "--sigma-scale", "1,10"]) == 0
    result = json.loads((out / "result.json").read_text())
    assert list(result["rows"]) == list(L.scenario("li2022-arc-slow").published)
    assert [s["rho"] for s in result["sweep"]] == [1.0, 10.0]
    assert len(result["rows"]["PL-MMSE-S"]["curves"]["bnorm_vel"]) == 200
    assert (out / "curves.png").stat().st_size > 10_000 and (out / "sweep.png").stat().st_size > 10_000
    printed = capsys.readouterr().out
    assert "Table 7" in printed and "IVKF-S" in printed and "rho=10" in printed
    again = tmp_path / "again"
    assert main(["tma", "reproduce", "li2022-arc-slow", "--runs", "10", "--seed", "3", "--out", str(again)]) == 0
    rows = json.loads((again / "result.json").read_text())["rows"]
    assert rows["PLKF-L"]["curves"] == result["rows"]["PLKF-L"]["curves"]  # same seed, same numbers


@pytest.mark.parametrize("argv, message", [
    (["huang2021-scenario2", "--sigma-scale", "2"], "applies to the li2022 studies only"),
    (["li2022-line", "--sigma-scale", "1,x"], "positive numbers"),
    (["li2022-line", "--sigma-scale", "-1"], "positive numbers"),
    (["li2022-line", "--runs", "1"], "--runs must be in [2, 1000000], got 1"),
])
def test_tma_reproduce_li2022_bad_input(argv, message, capsys, tmp_path):
    from uavsim.cli import main

    assert main(["tma", "reproduce", *argv, "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and message in err and err.count("\n") == 1
