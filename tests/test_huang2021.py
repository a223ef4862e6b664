"""The study of [Huang2021] Sec. 3 (studies/huang2021.py, its scenarios in
studies/huang2021_scenarios.py) and its command, ``uavsim tma reproduce huang2021-*``; the
filters themselves are tested in tests/test_plkf.py."""

import json

import numpy as np
import pytest

from uavsim.bounds.crlb import constrained, crlb
from uavsim.estimators import plkf
from uavsim.studies.huang2021 import reproduce, run_control, run_filter
from uavsim.studies.huang2021_scenarios import draw_runs, scenario


def test_scenarios_as_described():
    """Sec. 3.1-3.2: speeds, segment ends, zero bearing rate in scenario 1's last 120 scans,
    the observer's constant speed, the mismatch's noise windows."""
    s1, s2, mm = (scenario(n) for n in ("huang2021-scenario1", "huang2021-scenario2", "huang2021-mismatch"))
    assert len(s1.truth) == len(s2.truth) == 350
    rel = s1.truth[230:, :2] - s1.observer[230:]
    np.testing.assert_allclose(np.arctan2(rel[:, 1], rel[:, 0]), np.arctan2(rel[0, 1], rel[0, 0]), atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(np.diff(s1.observer[:180], axis=0), axis=1), 3.0)
    np.testing.assert_allclose(s2.truth[200:, 2:], np.tile([5.0, 5.0], (150, 1)))
    speed = np.linalg.norm(s2.truth[:, 2:], axis=1)
    assert s2.v_min <= speed.min() and speed.max() <= s2.v_max
    turn = np.diff(s2.observer, axis=0)
    np.testing.assert_allclose(np.linalg.norm(turn, axis=1), 9.45 * np.sinc(np.radians(1.8) / 2 / np.pi), rtol=1e-12)
    np.testing.assert_allclose(np.degrees(mm.sigma_true[[0, 49, 50, 200, 201]]), [3, 3, 7, 7, 3])
    assert mm.sigma == s2.sigma == np.radians(5)


def test_run_r_does_not_depend_on_the_number_of_runs():
    sc = scenario("huang2021-scenario2")
    x5, b5 = draw_runs(sc, 5, 7)
    x3, b3 = draw_runs(sc, 3, 7)
    np.testing.assert_array_equal(x5[:3], x3)
    np.testing.assert_array_equal(b5[:3], b3)


# The study, with the paper's 300 runs (0.4 s per scenario).  Per-run time-averaged
# squared errors give paired t-statistics over the 300 runs (seed 2021):
#
#   scenario 2, time-averaged position RMSE (m): PLKF 2678, BC 1524, IV 512, UB 2541,
#   VC 2207; CRLB 658, constrained CRLB 442.  IV < BC (t = 15.5), IV < VC (t = 17.1),
#   BC < UB (t = 5.1), VC < UB (t = 1.9).
#   mismatch - scenario 2: PLKF -3, BC +2096 (t = 18.6, 85% of runs worse),
#   IV +8883 (t = 1.0: a few runs diverge; its median run improves, 444 -> 412 m),
#   UB -139, VC +2.
#
# So with our reading of the scenario (studies/huang2021_scenarios.py: the one with the fewest lost minus
# signs) the paper's ordering in scenario 2 (UB, VC better than BC, IV; VC closest to the
# CRLB) is NOT reproduced: IV is best and UB worst.  The UB/VC pseudo-measurement is only
# right when the bearing prediction is (test_plkf.py's test_translation), so their accuracy depends on
# where the coordinate origin lies.  Over all 128 sign readings of scenario 2 (100 runs,
# seed 1) the paper's ordering held in 11: those where the target's own projection on the
# line of sight, u . p = m + d, is small against the range (median |m + d| / d 0.48-0.75,
# against 0.89 for the others).  The mismatch finding is reproduced for BC (large,
# reliable) but not reliably for IV.

@pytest.fixture(scope="module")
def study():
    return {n: reproduce(n, 300, 2021) for n in ("huang2021-scenario2", "huang2021-mismatch")}


def avg(study, name, kind):
    return study[name]["filters"][kind]["time_avg_rmse_pos_m"]


def test_scenario2_as_measured(study):
    """Documents the non-reproduction above: IV best (t >= 15), BC better than UB (t = 5).
    The scenario is informative for IV: it removes over half of the no-update control's
    error (68%; the control: the same runs, every bearing update off), BC a little (6%)."""
    s2 = "huang2021-scenario2"
    assert study[s2]["filters"]["iv-plkf"]["bought"] > 0.5 and study[s2]["filters"]["bc-plkf"]["bought"] > 0
    assert avg(study, s2, "iv-plkf") < min(avg(study, s2, k) for k in plkf.FILTERS if k != "iv-plkf")
    assert avg(study, s2, "bc-plkf") < avg(study, s2, "ub-plkf")
    assert study[s2]["ccrlb"]["time_avg_pos_m"] < study[s2]["crlb"]["time_avg_pos_m"]


def test_the_printed_bound_bounds_the_simulated_truth(study):
    """The truth of scenario 2 is a deterministic path, so its CRLB has no process noise
    (265 m time-averaged): no filter's RMSE goes below it beyond its Monte-Carlo error
    (2 standard errors of an RMSE over 300 runs, sqrt(1 / (2 x 300)) = 4.1% each) at any
    scan 60..350.  Measured: IV-PLKF comes nearest, 1.04x at its closest scan.  The paper's
    curve, computed with the filters' Q (658 m), is no bound for this truth: IV-PLKF is
    below it at 284 of those 291 scans, which is why it is printed apart, as the paper's."""
    r = study["huang2021-scenario2"]
    bound, paper = np.array(r["crlb"]["pos_m"])[59:], np.array(r["paper_crlb"]["pos_m"])[59:]
    floor = bound * (1 - 2 * np.sqrt(1 / (2 * r["runs"])))
    for kind, f in r["filters"].items():
        assert (np.array(f["rmse_pos_m"])[59:] >= floor).all(), kind
    assert (np.array(r["filters"]["iv-plkf"]["rmse_pos_m"])[59:] < paper).sum() > 250  # the control: it can fail
    assert r["crlb"]["time_avg_pos_m"] == pytest.approx(265.0, abs=0.5)


def test_mismatch_hurts_bc_and_not_ub_or_vc(study):
    """Fig. 7: BC degrades under the 3/7 deg mismatch (+2096 m, t = 18.6); UB and VC move
    by less than 10% (-139 m and +2 m).  Not a finding about the bearings: under the
    mismatch every filter is worse than the no-update control (the prior predicted), so
    this compares how much each filter's bias costs."""
    assert all(f["bought"] < 0 for f in study["huang2021-mismatch"]["filters"].values())
    d = {k: avg(study, "huang2021-mismatch", k) - avg(study, "huang2021-scenario2", k) for k in plkf.FILTERS}
    assert d["bc-plkf"] > 1000
    for k in ("ub-plkf", "vc-plkf"):
        assert abs(d[k]) < 0.1 * avg(study, "huang2021-scenario2", k)


def test_every_filter_stays_finite(study):
    for r in study.values():
        for f in r["filters"].values():
            assert f["diverged_runs"] == 0 and np.isfinite(f["rmse_pos_m"]).all()


def test_filters_run_on_scenario1():
    sc = scenario("huang2021-scenario1")
    x0, bearings = draw_runs(sc, 20, 1)
    for kind in plkf.FILTERS:
        est, _, _ = run_filter(kind, sc, x0, bearings)
        assert np.isfinite(est).all()


def test_tma_reproduce_command(tmp_path, capsys):
    from uavsim.cli import main

    assert main(["tma", "reproduce", "huang2021-scenario2", "--runs", "5", "--out", str(tmp_path)]) == 0
    result = json.loads((tmp_path / "result.json").read_text())
    assert set(result["filters"]) == set(plkf.FILTERS) and len(result["crlb"]["pos_m"]) == 350
    assert (tmp_path / "rmse.png").stat().st_size > 10_000
    assert "iv-plkf" in capsys.readouterr().out
    assert main(["tma", "reproduce", "huang2021-scenario2", "--runs", "1", "--out", str(tmp_path)]) == 2


# huang2021-scenario2-alt (studies/huang2021_scenarios.py): the reading of scenario 2 with 5 lost minus signs.
# 300 runs, seed 2021, time-averaged position RMSE (m): PLKF 3527, BC 1000, IV 730, UB 673,
# VC 635; CRLB 665, constrained CRLB 420.  Paired t over the runs: UB < BC 7.3, UB < IV 3.0,
# VC < BC 8.2, VC < IV 5.6, VC < UB 6.7 (seed 7: 9.1, 2.8, 9.9, 5.2, 7.5).  So under this
# reading the paper's ordering of Fig. 5 holds; under ours (huang2021-scenario2) it does not
# (IV best, UB worst, above).  The text cannot decide between them (docs/results/huang2021.md).

@pytest.fixture(scope="module")
def alt():
    sc = scenario("huang2021-scenario2-alt")
    x0, bearings = draw_runs(sc, 300, 2021)
    per_run = {}
    for kind in plkf.FILTERS:
        est, _, _ = run_filter(kind, sc, x0, bearings)
        per_run[kind] = np.sum((est[:, 59:, :2] - sc.truth[59:, :2]) ** 2, -1).mean(1)
    per_run["no-update"] = np.sum((run_control(sc, x0)[:, 59:, :2] - sc.truth[59:, :2]) ** 2, -1).mean(1)
    bound = crlb(sc.truth, sc.observer, sc.sigma_true, sc.f, sc.q, sc.p0)
    bounds = [np.sqrt(np.mean(b[59:, 0, 0] + b[59:, 1, 1])) for b in (bound, constrained(bound, sc.truth))]
    return sc, per_run, bounds


def test_alt_scenario_as_described(alt):
    """Target from (-1000, 1000) at (-10, -10) m/s, printed acceleration, ends at (-5, 5) m/s,
    speed inside the VC bounds [5, 16]; the observer leaves (500, 500) southward at 9.45 m/s."""
    sc = alt[0]
    np.testing.assert_allclose(sc.truth[0], [-1000, 1000, -10, -10])
    np.testing.assert_allclose(sc.truth[-1, 2:], [-5, 5], atol=1e-12)
    speed = np.linalg.norm(sc.truth[:, 2:], axis=1)
    assert sc.v_min <= speed.min() and speed.max() <= sc.v_max
    np.testing.assert_allclose(sc.observer[0], [500, 500])
    assert sc.observer[1, 1] < sc.observer[0, 1]


def test_alt_scenario_reproduces_the_papers_ordering(alt):
    """[Huang2021, Fig. 5 and Sec. 3.2]: UB and VC below BC and IV (paired t > 2.5, the weakest UB < IV
    at 3.0), VC the lowest and UB next, so VC is closest to the CRLB and CCRLB from above the
    CCRLB (the paper's wording); VC sits 5% under the unconstrained CRLB, which a filter
    using the speed constraint may.  Informative: UB and VC each remove over half of the
    no-update control's 1620 m (paired t > 5)."""
    _, per_run, (crlb_avg, ccrlb_avg) = alt

    def t(better, worse):
        d = per_run[worse] - per_run[better]
        return d.mean() / d.std(ddof=1) * np.sqrt(len(d))

    for good in ("ub-plkf", "vc-plkf"):
        for bad in ("bc-plkf", "iv-plkf"):
            assert t(good, bad) > 2.5, (good, bad)
        assert t(good, "no-update") > 5 and per_run[good].mean() < 0.25 * per_run["no-update"].mean()
    per_run = {k: v for k, v in per_run.items() if k != "no-update"}
    avg = {k: np.sqrt(v.mean()) for k, v in per_run.items()}
    assert sorted(avg, key=avg.get)[:2] == ["vc-plkf", "ub-plkf"]
    assert ccrlb_avg < avg["vc-plkf"] and abs(avg["vc-plkf"] - crlb_avg) < 0.1 * crlb_avg
