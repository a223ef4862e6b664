"""``atan2`` into a buffer, float32 vectorised on every CPU.

numpy's float32 ``arctan2`` runs a SIMD loop only where it has one for the CPU (AVX-512);
elsewhere it calls the C library element by element, about 25 ns an element, and in the
kernels that take millions of residual angles a step (the UAV's decision, Eq. (12); the
swarms of the batch estimators) it became most of their time.  There :func:`atan2_into`
takes the angle from the odd polynomial :data:`ATAN_COEFFS` of
``t = min(|x|, |y|) / max(|x|, |y|)`` in [0, 1], reflected to ``pi / 2 - a`` where
``|y| > |x|``, to ``pi - a`` where ``x < 0`` and negated where ``y < 0``, with float32
passes numpy does vectorise (about 5 ns an element): within 4e-7 rad of arctan2 (the
fit's 1.6e-7 and float32's rounding of ``pi - a``), and 2.3e-7 relative for small angles,
as numpy's own float32 loop.  Where numpy's loop is vectorised it is used, and for other
dtypes numpy's ``arctan2`` always (a float64 polynomial as exact would need twice the terms).
The simulator's decision uses it too (:mod:`uavsim.belief.traces`).
"""

from __future__ import annotations

import numpy as np

# atan(t) = t sum_k c_k t^(2k) on [0, 1]: least squares in relative error on 40 000 Chebyshev
# nodes with c_0 = 1 (exact for small angles); in float32 within 1.6e-7 rad (tests/test_angles.py)
ATAN_COEFFS = np.array([1.0, -0.33332406995407804, 0.19974286379233538, -0.14040931055609907,
                        0.09965593668801892, -0.06014166411412691, 0.02467854849336771,
                        -0.00480422211511922], np.float32)


def atan2_into(y: np.ndarray, x: np.ndarray, squared: bool = False) -> np.ndarray:
    """``atan2(y, x)`` (or its square) of arrays of one shape and dtype, in ``y``'s buffer;
    ``x`` may be overwritten (module docstring)."""
    if ARCTAN2_VECTORISED or y.dtype != np.float32:
        a = np.arctan2(y, x, out=y)
        return np.square(a, out=a) if squared else a
    below = None if squared else y < 0
    behind, steep = x < 0, np.abs(x, out=x) < np.abs(y, out=y)
    big = np.maximum(x, y)
    big += np.float32(1e-30)  # 0 / 0 -> 0 (and a pass faster than a maximum with a scalar)
    t = np.divide(np.minimum(x, y, out=y), big, out=y)  # in [0, 1]
    z = np.multiply(t, t, out=big)
    acc = np.multiply(z, ATAN_COEFFS[-1], out=x)
    for c in ATAN_COEFFS[-2:0:-1]:
        acc += c
        acc *= z
    acc += ATAN_COEFFS[0]
    a = np.multiply(acc, t, out=t)  # atan(t), in [0, pi / 4]
    for flag, turn in ((steep, np.float32(np.pi / 2)), (behind, np.float32(np.pi))):
        np.multiply(a, np.float32(-2.0), out=z)  # a + flag (turn - 2 a): no masked passes (slow)
        z += turn
        z *= flag
        a += z
    if squared:
        return np.square(a, out=a)
    np.multiply(below, np.float32(-2.0), out=z)
    z += np.float32(1.0)  # -1 where y < 0
    a *= z
    return a


def _numpy_arctan2_vectorised() -> bool:
    """Whether numpy runs a SIMD loop for float32 ``arctan2`` on this CPU (its own
    introspection; an older numpy without it is taken as not)."""
    try:
        info = np.lib.introspect.opt_func_info(func_name="arctan2", signature="float32")
        return not info["arctan2"]["fff"]["current"].startswith("baseline")
    except (AttributeError, KeyError, TypeError):
        return False


ARCTAN2_VECTORISED = _numpy_arctan2_vectorised()
