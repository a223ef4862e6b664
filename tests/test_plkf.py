"""The PLKF family, the CRLB and the study of [Huang2021] (Huang et al. 2021).

Hand steps use one prediction ``x- = [10, 0, 1, 0]``, ``P- = I``, observer ``s = (-10, 0)``,
measured bearing 0.1 rad, sigma 0.05 rad: the predicted range is 20 m, so the PLKF's
``R = d^2 sigma^2 = 1`` and its innovation variance is 2.
"""

import numpy as np
import pytest

from uavsim.bounds.crlb import bearing_gradients, constrained, crlb
from uavsim.estimators import plkf
from uavsim.studies.huang2021 import reproduce, run_control, run_filter
from uavsim.studies.huang2021_scenarios import draw_runs, scenario

X, P, S, B, SIG = np.array([[10.0, 0, 1, 0]]), np.eye(4)[None], np.array([-10.0, 0]), 0.1, 0.05
sb, cb = np.sin(B), np.cos(B)


def test_plkf_step_by_hand():
    """Eq. (8), (11)-(13): H = [sin b, -cos b, 0, 0], z = -10 sin b, innovation -20 sin b."""
    x, p, ok = plkf.plkf_update(X, P, B, S, SIG)
    h = np.array([sb, -cb, 0, 0])
    assert ok.all()
    np.testing.assert_allclose(x[0], [10 - 10 * sb**2, 10 * sb * cb, 1, 0], atol=1e-12)
    np.testing.assert_allclose(p[0], np.eye(4) - np.outer(h, h) / 2, atol=1e-12)


def test_bc_plkf_step_by_hand():
    """Eq. (28) step 6: the PLKF update plus (sigma^2 / R) P M^T (M x - s), sigma^2 / R = 0.0025."""
    x_pl, p_pl, _ = plkf.plkf_update(X, P, B, S, SIG)
    x, p, ok = plkf.bc_plkf_update(X, P, B, S, SIG)
    np.testing.assert_allclose(x[0], x_pl[0] + 0.0025 * p_pl[0][:, :2] @ (x_pl[0, :2] - S), atol=1e-12)
    np.testing.assert_allclose(p, p_pl)
    assert x[0, 0] > x_pl[0, 0]  # compensation pushes the estimate out along the line of sight


def test_iv_plkf_step_by_hand():
    """IV step 7: G from the BC bearing; K = G^T / (R + H G^T) with P- = I; P = I - K H (symmetric part)."""
    x_bc, _, _ = plkf.bc_plkf_update(X, P, B, S, SIG)
    beta_bc = np.arctan2(x_bc[0, 1] - S[1], x_bc[0, 0] - S[0])
    g, h = np.array([np.sin(beta_bc), -np.cos(beta_bc), 0, 0]), np.array([sb, -cb, 0, 0])
    k = g / (1.0 + h @ g)
    x, p, ok = plkf.iv_plkf_update(X, P, B, S, SIG)
    np.testing.assert_allclose(x[0], X[0] + k * (-20 * sb), atol=1e-12)
    full = np.eye(4) - np.outer(k, h)
    np.testing.assert_allclose(p[0], (full + full.T) / 2, atol=1e-12)


def test_ub_plkf_step_by_hand():
    """Eq. (43)-(52) in the paper's divided form: beta^ = 0, m = -10, z_bar = sin b,
    H_bar = [0, 0.1, 0, 0], W = 0.0025 + 0.01, K = [0, 8, 0, 0]: y = 8 sin b, P_yy = 0.2."""
    x, p, ok = plkf.ub_plkf_update(X, P, B, S, SIG)
    np.testing.assert_allclose(x[0], [10, 8 * sb, 1, 0], atol=1e-12)
    np.testing.assert_allclose(p[0], np.diag([1, 0.2, 1, 1]), atol=1e-12)


@pytest.mark.parametrize("v_min, v_max, speed", [(0.5, 2.0, 1.0), (0.0, 0.5, 0.5), (2.0, 9.0, 2.0)])
def test_vc_plkf_step_by_hand(v_min, v_max, speed):
    """Eq. (80): inside the bounds the UB update; outside, the velocity scaled to the bound
    (Eq. 68), with the Joseph covariance of K*: K*_vx = (v/1 - 1) / eps, eps = -10 sin b,
    P_vx,vx = 1 + K*^2 (H P H^T = 1) + R K*^2 (R = m^2 sigma^2 = 0.25)."""
    x, p, ok = plkf.vc_plkf_update(X, P, B, S, SIG, v_min=v_min, v_max=v_max)
    x_ub, p_ub, _ = plkf.ub_plkf_update(X, P, B, S, SIG)
    np.testing.assert_allclose(x[0], [10, 8 * sb, speed, 0], atol=1e-12)
    k = (speed - 1.0) / (-10 * sb)
    np.testing.assert_allclose(p[0, 2, 2], 1 + 1.25 * k**2, atol=1e-12)
    if speed == 1.0:
        np.testing.assert_allclose(p, p_ub)
    np.testing.assert_allclose(p[0], p[0].T)


@pytest.mark.parametrize("kind", plkf.FILTERS)
def test_batched_step_equals_one_run_at_a_time(kind):
    rng = np.random.default_rng(3)
    x = rng.normal([500, 300, 2, 1], [30, 30, 1, 1], (7, 4))
    a = rng.normal(size=(7, 4, 4))
    p = a @ a.transpose(0, 2, 1) + 10 * np.eye(4)
    beta, s = rng.uniform(-np.pi, np.pi, 7), rng.normal(0, 100, (7, 2))
    kw = {"v_min": 1.0, "v_max": 2.0} if kind == "vc-plkf" else {}
    xb, pb, _ = plkf.UPDATES[kind](x, p, beta, s, 0.05, **kw)
    for r in range(7):
        x1, p1, _ = plkf.UPDATES[kind](x[r:r + 1], p[r:r + 1], beta[r], s[r], 0.05, **kw)
        np.testing.assert_allclose(xb[r], x1[0], rtol=1e-12, atol=1e-9)
        np.testing.assert_allclose(pb[r], p1[0], rtol=1e-12, atol=1e-9)


@pytest.mark.parametrize("kind", plkf.FILTERS)
def test_translation(kind):
    """PLKF, BC and IV are translation equivariant; UB and VC are not: ``m = u . s`` (Eq. 51)
    depends on where the origin is.  This is why the UB/VC results hinge on the scenario's
    coordinates (see the study test below)."""
    c = np.array([300.0, -200.0])
    shift = np.array([*c, 0, 0])
    kw = {"v_min": 0.0, "v_max": 0.5} if kind == "vc-plkf" else {}
    x1, _, _ = plkf.UPDATES[kind](X, P, B, S, SIG, **kw)
    x2, _, _ = plkf.UPDATES[kind](X + shift, P, B, S + c, SIG, **kw)
    moved = np.abs(x2 - shift - x1).max()
    if kind in ("ub-plkf", "vc-plkf"):
        assert moved > 0.1
    else:
        assert moved < 1e-9


def test_degenerate_update_is_reported_and_skipped():
    """UB with the observer at the origin (m = 0, so R = 0) and no position variance across
    the line of sight: zero innovation variance.  The run keeps its prediction, no NaN."""
    p = np.diag([1.0, 0.0, 1.0, 1.0])[None]
    kf = plkf.PseudoLinearKF("ub-plkf", np.eye(4), np.zeros((4, 4)), X, p)
    kf.step(B, np.zeros(2), SIG)
    np.testing.assert_array_equal(kf.x, X)
    assert kf.degenerate.tolist() == [1] and np.isfinite(kf.p).all()


def test_unknown_filter_is_refused():
    with pytest.raises(ValueError, match="choose from plkf"):
        plkf.PseudoLinearKF("ekf", np.eye(4), np.eye(4), X, P)


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
# right when the bearing prediction is (test_translation), so their accuracy depends on
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
    import json

    from uavsim.cli import main

    assert main(["tma", "reproduce", "huang2021-scenario2", "--runs", "5", "--out", str(tmp_path)]) == 0
    result = json.loads((tmp_path / "result.json").read_text())
    assert set(result["filters"]) == set(plkf.FILTERS) and len(result["crlb"]["pos_m"]) == 350
    assert (tmp_path / "rmse.png").stat().st_size > 10_000
    assert "iv-plkf" in capsys.readouterr().out
    assert main(["tma", "reproduce", "huang2021-scenario2", "--runs", "1", "--out", str(tmp_path)]) == 2


def test_ub_plkf_is_a_bearing_ekf_with_a_scaled_jacobian():
    """plkf.py docstring: the UB update equals an EKF
    update on the bearing with Jacobian alpha * grad beta, alpha = -d^ / (u^ . s), noise
    sigma^2 and innovation sin delta + (cos delta - 1) (n^ . s) / (u^ . s); checked on random
    geometries (alpha from -16 to 82, median |alpha| 2.5)."""
    rng = np.random.default_rng(11)
    r = 50
    x = rng.normal([800, -300, 5, -2], [400, 400, 3, 3], (r, 4))
    a = rng.normal(size=(r, 4, 4))
    p = a @ a.transpose(0, 2, 1) * 50 + np.eye(4)
    s, sigma = rng.normal(0, 500, (r, 2)), 0.03
    rel = x[:, :2] - s
    beta_hat = np.arctan2(rel[:, 1], rel[:, 0])
    beta = beta_hat + rng.normal(0, sigma, r)
    d_hat = np.linalg.norm(rel, axis=1)
    u = np.stack([np.cos(beta_hat), np.sin(beta_hat)], -1)
    n = np.stack([np.sin(beta_hat), -np.cos(beta_hat)], -1)
    alpha = -d_hat / np.einsum("ri,ri->r", u, s)
    h = np.zeros((r, 4))
    h[:, :2] = alpha[:, None] * np.stack([-np.sin(beta_hat), np.cos(beta_hat)], -1) / d_hat[:, None]
    delta = beta - beta_hat
    innov = np.sin(delta) + (np.cos(delta) - 1) * np.einsum("ri,ri->r", n, s) / np.einsum("ri,ri->r", u, s)
    ph = np.einsum("rij,rj->ri", p, h)
    k = ph / (np.einsum("ri,ri->r", h, ph) + sigma**2)[:, None]
    x_ekf = x + k * innov[:, None]
    p_ekf = p - k[:, :, None] * ph[:, None, :]
    x_ub, p_ub, ok = plkf.ub_plkf_update(x, p, beta, s, sigma)
    assert ok.all() and np.abs(alpha).max() > 5
    np.testing.assert_allclose(x_ub, x_ekf, rtol=1e-10, atol=1e-8)
    np.testing.assert_allclose(p_ub, (p_ekf + p_ekf.transpose(0, 2, 1)) / 2, rtol=1e-9, atol=1e-7)


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
    """002 Fig. 5 / Sec. 3.2: UB and VC below BC and IV (paired t > 2.5, the weakest UB < IV
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
