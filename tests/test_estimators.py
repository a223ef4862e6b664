"""The estimator library's one interface: package-level imports, the two bearing
conventions, and every user mistake an adversarial tester made ending in a clear error
or warning (bearings or sigma in degrees, NaN bearings, a non-PSD prior, wrong shapes,
too few scans, a degenerate update)."""

import re
import warnings

import numpy as np
import pytest

from uavsim.estimators import PLKF, PLMMSE, BatchTMA, DegenerateUpdateWarning, GaussianMixture, convert

K = 60
TIMES = np.arange(K, dtype=float)
TRUTH = np.column_stack([2000 + 10 * TIMES, 3000 - 5 * TIMES])  # (K, 2) m
OBS = np.column_stack([300 * np.sin(TIMES / 10), 100 * TIMES])  # the observer weaves north
SIGMA = np.radians(1.0)
PRIOR = dict(x0=[1500.0, 3500.0, 0.0, 0.0], P0=np.diag([1e6, 1e6, 100.0, 100.0]), q=0.01)


def bearings(seed=0):
    """North-clockwise bearings (the simulator's convention) with 1 deg noise."""
    d = TRUTH - OBS
    return np.arctan2(d[:, 0], d[:, 1]) + np.random.default_rng(seed).normal(0, SIGMA, K)


def test_conventions_are_mirror_images_and_give_the_same_estimate():
    """atan2(dx, dy) = pi/2 - atan2(dy, dx) (mod 2 pi): by hand at 0, 90 and 180 deg, and
    a filter given the same data in either convention returns the same track."""
    np.testing.assert_allclose(convert([0.0, np.pi / 2, np.pi], "north-cw", "east-ccw"),
                               [np.pi / 2, 0.0, np.pi / 2 - np.pi])
    b = bearings()
    north = PLMMSE(SIGMA, **PRIOR).filter(TIMES, b, OBS)[0]
    east = PLMMSE(SIGMA, convention="east-ccw", **PRIOR).filter(TIMES, convert(b, "north-cw", "east-ccw"), OBS)[0]
    np.testing.assert_allclose(north, east, rtol=1e-9, atol=1e-6)


def test_the_bearings_buy_an_estimate_the_prior_alone_does_not_give():
    """Against the no-update control (every scan missed: dead reckoning from the prior),
    PL-MMSE's final position error is at least 5x smaller on each of 3 noise draws
    (1349 m against 22-153 m)."""
    control = PLMMSE(SIGMA, **PRIOR).filter(TIMES, np.full(K, np.nan), OBS)[0]
    err_control = np.hypot(*(control[-1, :2] - TRUTH[-1]))
    for seed in range(3):
        track = PLMMSE(SIGMA, **PRIOR).filter(TIMES, bearings(seed), OBS)[0]
        assert np.hypot(*(track[-1, :2] - TRUTH[-1])) < err_control / 5


def test_degrees_are_refused_unless_asked_for():
    b = bearings()
    for make in (lambda: PLMMSE(SIGMA, **PRIOR), lambda: PLKF(SIGMA, **PRIOR)):
        with pytest.raises(ValueError, match=r"outside \[-2 pi, 2 pi\]: probably degrees; pass units='deg'"):
            make().filter(TIMES, np.degrees(b), OBS)
    with pytest.raises(ValueError, match=r"outside \[-2 pi, 2 pi\]: probably degrees"):
        BatchTMA(SIGMA).fit(TIMES, np.degrees(b), OBS)
    with pytest.raises(ValueError, match=r"sigma = 1 rad \(57.3 deg\) is above 0.5 rad: probably degrees"):
        PLMMSE(1.0, **PRIOR)
    with pytest.raises(ValueError, match="probably degrees"):
        BatchTMA(1.0)
    in_degrees = PLMMSE(1.0, units="deg", **PRIOR).filter(TIMES, np.degrees(b), OBS)[0]
    np.testing.assert_allclose(in_degrees, PLMMSE(SIGMA, **PRIOR).filter(TIMES, b, OBS)[0], rtol=1e-9, atol=1e-6)


def test_a_nan_bearing_is_a_missed_scan_not_a_nan_track():
    b = bearings()
    b[[5, 30]] = np.nan
    f = PLMMSE(SIGMA, **PRIOR)
    tracks, covs = f.filter(TIMES, b, OBS)
    assert np.all(np.isfinite(tracks)) and np.all(np.isfinite(covs)) and f.missed == 2
    assert f.update(None, OBS[0]) and f.missed == 3
    with pytest.raises(ValueError, match="not finite"):
        BatchTMA(SIGMA).fit(TIMES, b, OBS)


@pytest.mark.parametrize("p0, message", [
    (np.diag([1e6, 1e6, 100.0, -1.0]), "not positive definite"),
    (np.array([[1, 2, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]), "not symmetric"),
    (np.eye(3), r"P0 must be a finite 4x4 matrix \(or 4 variances\); got shape \(3, 3\)"),
])
def test_a_bad_prior_covariance_is_refused(p0, message):
    with pytest.raises(ValueError, match=message):
        PLMMSE(SIGMA, x0=[0, 0, 0, 0], P0=p0)


def test_wrong_shapes_are_named():
    with pytest.raises(ValueError, match=r"observers has shape \(59, 2\); expected \(60, 2\)"):
        PLMMSE(SIGMA, **PRIOR).filter(TIMES, bearings(), OBS[1:])
    with pytest.raises(ValueError, match=r"times has shape \(59,\); expected \(60,\)"):
        BatchTMA(SIGMA).fit(TIMES[1:], bearings(), OBS)
    with pytest.raises(ValueError, match="K >= 4 scans for the 4 unknowns"):
        BatchTMA(SIGMA).fit(TIMES[:1], bearings()[:1], OBS[:1])
    with pytest.raises(ValueError, match="strictly increasing"):
        PLKF(SIGMA, **PRIOR).filter(TIMES[::-1], bearings(), OBS)


def test_a_degenerate_update_is_a_warning():
    """The observer on the estimated target, whose position is all but certain: the
    pseudo-linear update's innovation variance (d^2 sigma^2 + H P H^T, d = 0) is below
    1e-300, so it is skipped, counted, and a DegenerateUpdateWarning says so."""
    f = PLKF(SIGMA, x0=[100.0, 100.0, 0.0, 0.0], P0=np.diag([1e-301, 1e-301, 1.0, 1.0]))
    with pytest.warns(DegenerateUpdateWarning, match="degenerate"):
        ok = f.update(0.3, [100.0, 100.0])
    assert not ok and f.degenerate == 1 and np.all(np.isfinite(f.x))


def test_batch_estimator_protocol():
    """fit -> self with x_, cov_, converged_; predict(times) moves x_ at constant
    velocity; get_params / set_params round-trip and check like the constructor."""
    est = BatchTMA(SIGMA, method="nr", rng=np.random.default_rng(1))
    assert est.fit(TIMES, bearings(), OBS) is est
    track = est.predict(TIMES)
    assert track.shape == (K, 4) and est.cov_.shape == (4, 4)
    np.testing.assert_allclose(track[0], est.x_)
    np.testing.assert_allclose(track[-1, :2], est.x_[:2] + (K - 1) * est.x_[2:])
    assert est.get_params()["method"] == "nr" and est.set_params(method="pso").method == "pso"
    with pytest.raises(ValueError, match="unknown parameters"):
        est.set_params(methd="nr")


def test_mixture_noise_is_given_in_radians():
    noise = GaussianMixture([0.7, 0.3], [np.radians(0.5) ** 2, np.radians(3.0) ** 2])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        tracks, _ = PLMMSE(noise, **PRIOR).filter(TIMES, bearings(), OBS)
    assert np.all(np.isfinite(tracks))
    with pytest.raises(ValueError, match="probably degrees"):
        PLMMSE(GaussianMixture([1.0], [3.0**2]), **PRIOR)


# ------------------------------------------------------------------ one contract, every estimator
def every_estimator():
    """One of each estimator class and kind, with the library's defaults where it has them."""
    from uavsim.estimators import ConstrainedMLE

    rng = np.random.default_rng(0)
    return ([PLKF(SIGMA, kind=k, **PRIOR) for k in ("plkf", "bc-plkf", "iv-plkf", "ub-plkf", "vc-plkf")]
            + [PLMMSE(SIGMA, kind=k, **PRIOR) for k in ("pl-mmse", "plkf", "bc-plkf", "ivkf")]
            + [BatchTMA(SIGMA, method=m, rng=rng, n_candidates=500, n_particles=50, n_iter=5)
               for m in ("nr", "pso", "nrpso")]
            + [ConstrainedMLE(SIGMA, order=1)])


@pytest.mark.parametrize("est", every_estimator(), ids=lambda e: f"{type(e).__name__}-"
                         f"{e.get_params().get('kind', e.get_params().get('method', 'mle'))}")
def test_every_estimator_keeps_one_contract(est):
    """In the spirit of scikit-learn's check_estimator: the same default convention and
    units; get_params / set_params / a clone from the parameters (each the very object
    given); unknown parameters refused; results only after fit (NotFittedError, a
    ValueError too); predict returns (K, 4) states for the batch estimators; a recursive
    filter's reset() puts it back at its prior (a second filter() used to continue from
    the first one's posterior)."""
    from uavsim.estimators.api import NotFittedError

    params = est.get_params()
    assert params["convention"] == "north-cw" and params["units"] == "rad"
    clone = type(est)(**params)
    assert all(clone.get_params()[k] is v for k, v in params.items())
    assert est.set_params(**{"units": "rad"}) is est
    with pytest.raises(ValueError, match="unknown parameters"):
        est.set_params(nonsense=1)
    b = bearings()
    if hasattr(est, "fit"):
        with pytest.raises(NotFittedError):
            est.predict(TIMES)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fitted = est.fit(TIMES, b, OBS)
        assert fitted is est and est.predict(TIMES).shape == (K, 4) and est.cov_.shape[-2:] == (4, 4)
        states, covs = est.predict(TIMES, return_cov=True)
        np.testing.assert_allclose(states[0], est.x_[:4])
        np.testing.assert_allclose(covs[0], est.cov_[:4, :4])  # at the fitted time: the estimate's own
        assert isinstance(NotFittedError("x"), ValueError)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            batch = type(est)(**params).fit(TIMES, np.stack([b, bearings(1)]), OBS)  # (R, K): two runs at once
        assert batch.x_.shape[0] == 2 and batch.predict(TIMES, return_cov=True)[1].shape == (2, K, 4, 4)
    else:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            first = est.filter(TIMES, b, OBS)[0]
        assert not np.allclose(est.x, PRIOR["x0"])
        np.testing.assert_array_equal(est.reset().x, PRIOR["x0"])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            np.testing.assert_array_equal(est.filter(TIMES, b, OBS)[0], first)  # the same run again


@pytest.mark.parametrize("make, message", [
    (lambda: BatchTMA(SIGMA, max_iter=-5), "max_iter must be an integer in [1, inf]; got -5"),
    (lambda: BatchTMA(SIGMA, tol=np.nan), "tol must be a number in [0, inf]; got nan"),
    (lambda: BatchTMA(SIGMA, alpha=np.nan), "alpha must be a number in [0, inf]; got nan"),
    (lambda: BatchTMA(SIGMA, n_candidates=0), "n_candidates must be an integer in [1, inf]; got 0"),
    (lambda: PLKF(SIGMA, kind="vc-plkf", v_min=5.0, v_max=2.0, **PRIOR), "v_max must be a number in [5, inf]"),
    (lambda: PLKF(SIGMA, kind="vc-plkf", v_max=np.nan, **PRIOR), "v_max must be a number in [0, inf]; got nan"),
    (lambda: PLKF(SIGMA, **PRIOR).predict(np.nan), "dt must be a number in [0, inf]; got nan"),
    (lambda: PLKF(SIGMA, **PRIOR).predict(-100.0), "dt must be a number in [0, inf]; got -100"),
    (lambda: PLKF(SIGMA, **PRIOR).predict(np.inf), "dt must be a number in [0, inf]; got inf"),
])
def test_every_numeric_argument_is_checked(make, message):
    """Each was accepted (or a ZeroDivisionError) before."""
    with pytest.raises(ValueError, match=re.escape(message)):
        make()


def test_a_sigma_that_looks_like_degrees_is_a_hint():
    """sigma = 0.5 meant as degrees is 29 degrees in radians: valid, but a UnitsWarning asks."""
    from uavsim.estimators.api import UnitsWarning

    with pytest.warns(UnitsWarning, match=r"sigma = 0.5 rad is 28.6 deg.*pass units='deg'"):
        PLKF(0.5, **PRIOR)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        PLKF(0.5, units="deg", **PRIOR)
        PLKF(SIGMA, **PRIOR)


def test_ub_and_vc_say_their_estimate_depends_on_the_origin():
    """[Huang2021]'s scenario 2: UB- and VC-PLKF weigh the bearings by alpha = -d / (u . s),
    far from 1 at most scans there (the target 1-2 km from an origin it keeps leaving);
    translating the scenario moves their track (and not IV-PLKF's), and an OriginWarning
    says so; IV-PLKF raises none."""
    from uavsim.estimators import OriginWarning
    from uavsim.studies.huang2021_scenarios import draw_runs, scenario

    sc = scenario("huang2021-scenario2")
    x0, b = draw_runs(sc, 1, 5)
    t = np.arange(len(sc.truth), dtype=float)

    def run(kind, shift):
        f = PLKF(sc.sigma, x0[0] + np.r_[shift, 0.0, 0.0], sc.p0, kind=kind, convention="east-ccw")
        return f.filter(t, b[0], sc.observer + shift)[0][:, :2] - shift

    for kind in ("ub-plkf", "vc-plkf"):
        with pytest.warns(OriginWarning, match=rf"{kind}: its estimate depends on the coordinate origin"):
            a = run(kind, np.zeros(2))
        with pytest.warns(OriginWarning):
            moved = run(kind, np.array([2000.0, 0.0]))
        assert np.abs(a - moved).max() > 100  # metres: the translation changed the track
    with warnings.catch_warnings():
        warnings.simplefilter("error", OriginWarning)
        np.testing.assert_allclose(run("iv-plkf", np.zeros(2)), run("iv-plkf", np.array([2000.0, 0.0])), atol=1e-5)


def test_compass_bearings_in_radians_are_wrapped_not_refused():
    """A bearing in [0, 2 pi) (compass style) or a noisy one just past pi is radians: it
    was refused as "probably degrees" above pi; now it gives the same track as its
    wrapped value (bearings of this data shifted by 2 pi where negative)."""
    b = bearings()
    compass = np.where(b < 0, b + 2 * np.pi, b) + 0.0
    compass[0] = np.pi + 0.01  # just past pi, as noise makes it
    wrapped = compass.copy()
    wrapped[0] -= 2 * np.pi
    for make in (lambda: PLMMSE(SIGMA, **PRIOR), lambda: PLKF(SIGMA, kind="iv-plkf", **PRIOR)):
        np.testing.assert_allclose(make().filter(TIMES, compass, OBS)[0], make().filter(TIMES, wrapped, OBS)[0],
                                   rtol=1e-9, atol=1e-6)


def test_batches_and_predicted_covariances_are_the_single_runs_and_hand_values():
    """ConstrainedMLE fitted on (R, K) bearings equals R single fits (to 1e-6 m); a
    predicted covariance is cov_ carried along the constant-velocity track: the position
    variance at dt is P_xx + 2 dt P_xvx + dt^2 P_vxvx, written out here."""
    from uavsim.estimators import ConstrainedMLE

    runs = np.stack([bearings(s) for s in range(3)])
    batch = ConstrainedMLE(SIGMA, order=1).fit(TIMES, runs, OBS)
    for r in range(3):
        one = ConstrainedMLE(SIGMA, order=1).fit(TIMES, runs[r], OBS)
        np.testing.assert_allclose(batch.x_[r], one.x_, atol=1e-6)
        np.testing.assert_allclose(batch.cov_[r], one.cov_, rtol=1e-6)
        assert batch.converged_[r] == one.converged_
    for est in (batch, BatchTMA(SIGMA, method="nr", rng=np.random.default_rng(2)).fit(TIMES, runs, OBS)):
        _, covs = est.predict(TIMES, return_cov=True)
        p, dt = est.cov_, TIMES[-1] - TIMES[0]
        np.testing.assert_allclose(covs[:, -1, 0, 0], p[:, 0, 0] + 2 * dt * p[:, 0, 2] + dt**2 * p[:, 2, 2],
                                   rtol=1e-9)
        np.testing.assert_allclose(covs[:, -1, 2, 2], p[:, 2, 2], rtol=1e-12)
