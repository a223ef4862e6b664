"""atan2 into a buffer (uavsim/estimators/angles.py): the float32 polynomial that stands in
for numpy's scalar arctan2, against float64 arctan2."""

import numpy as np
import pytest

from uavsim.estimators import angles


@pytest.fixture
def polynomial(monkeypatch):
    monkeypatch.setattr(angles, "ARCTAN2_VECTORISED", False)


def circle():
    """Angles in every octant, on the axes and near 0, over 12 decades of magnitude, then
    0 / 0, 0 / 3 and 5 / 0: float32 ``(y, x)`` and float64 ``arctan2`` of them."""
    rng = np.random.default_rng(11)
    angle = np.r_[rng.uniform(-np.pi, np.pi, 20000), np.arange(-4, 5) * np.pi / 4, 10.0 ** -np.arange(1, 8),
                  -(10.0 ** -np.arange(1, 8))]
    scale = 10.0 ** rng.uniform(-6, 6, angle.size)
    y, x = (np.sin(angle) * scale).astype(np.float32), (np.cos(angle) * scale).astype(np.float32)
    y, x = np.r_[y, 0, 0, 5], np.r_[x, 0, 3, 0]
    return y, x, np.arctan2(y.astype(float), x.astype(float))


def test_signed_angles_match_arctan2_round_the_circle(polynomial):
    """Within 4e-7 rad (1.6e-7 the fit, plus float32's rounding of pi - a, 1.2e-7; +-pi
    counted equal), within 5e-7 relative below 0.1 rad (the residuals the likelihoods see
    are a few sigma), with arctan2's sign, and 0 at 0 / 0."""
    y, x, want = circle()
    got = angles.atan2_into(y.copy(), x.copy()).astype(float)
    err = np.abs(np.angle(np.exp(1j * (got - want))))  # +-pi are one angle
    assert err.max() < 4e-7
    small = (np.abs(want) > 0) & (np.abs(want) < 0.1)
    assert (err[small] / np.abs(want[small])).max() < 5e-7
    inside = np.abs(want) < np.pi - 1e-6
    assert np.array_equal(np.sign(got[inside]), np.sign(want[inside]))
    assert got[-3] == 0.0 and got[-2] == 0.0


def test_squared_angles_are_the_squares(polynomial):
    y, x, want = circle()
    got = np.sqrt(angles.atan2_into(y.copy(), x.copy(), squared=True).astype(float))
    assert np.abs(got - np.abs(want)).max() < 4e-7


def test_numpys_loop_where_it_is_vectorised(monkeypatch):
    """The other path is numpy's arctan2 itself, bit for bit."""
    monkeypatch.setattr(angles, "ARCTAN2_VECTORISED", True)
    y, x, _ = circle()
    np.testing.assert_array_equal(angles.atan2_into(y.copy(), x.copy()), np.arctan2(y, x))


def test_other_dtypes_take_numpys_loop(polynomial):
    y, x, want = circle()
    np.testing.assert_array_equal(angles.atan2_into(y.astype(float), x.astype(float)), want)
