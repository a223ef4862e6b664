"""Bearing sensor ([Papaioannou2023, Eq. (4), Sec. III-C]): convention by hand, statistics with seeds.

Statistical tolerances are 5 standard errors of the estimator for the sample size used,
so a correct sensor fails with probability below 1e-6 per check.
"""

import numpy as np
import pytest

from uavsim.sensing import Sensor, bearing, observe, wrap_angle

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
    sensor = Sensor(sigma=np.radians(1.0), p_detect=0.95, clutter_rate=rate)
    scan, _ = scan_many(sensor)
    n = N_CHANNELS
    clutter = (scan.valid & ~scan.from_target).sum(axis=1)
    assert abs(clutter.mean() - rate) < 5 * np.sqrt(rate / n)
    # Var of the sample variance of Poisson(L): (mu4 - sigma^4) / n = (L + 2 L^2) / n
    assert abs(clutter.var() - rate) < 5 * np.sqrt((rate + 2 * rate**2) / n)


def test_detection_frequency_and_residual_std():
    sigma = np.radians(1.0)
    sensor = Sensor(sigma=sigma, p_detect=0.95, clutter_rate=1.0)
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
    sensor = Sensor(sigma=np.radians(1.0), p_detect=0.0, clutter_rate=2.0)
    scan, _ = scan_many(sensor)
    c = scan.bearings[scan.valid]
    assert not scan.from_target.any()
    assert np.all(c > -PI) and np.all(c <= PI)
    frac = np.histogram(c, bins=4, range=(-PI, PI))[0] / c.size
    assert np.all(np.abs(frac - 0.25) < 5 * np.sqrt(0.25 * 0.75 / c.size))


def test_no_clutter_full_detection_shape_and_determinism():
    sensor = Sensor(sigma=0.01, p_detect=1.0, clutter_rate=0.0)
    t = np.array([[0.0, 10.0, 0.0], [10.0, 0.0, 0.0]])
    s = np.array([0.0, 0.0, 40.0])
    a = observe(np.random.default_rng(3), sensor, t, s)
    b = observe(np.random.default_rng(3), sensor, t, s)
    assert a.bearings.shape == (2, 1) and a.valid.all() and a.from_target.all()
    np.testing.assert_array_equal(a.bearings, b.bearings)
    np.testing.assert_allclose(a.bearings[:, 0], [0.0, PI / 2], atol=0.05)
