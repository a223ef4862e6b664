"""Recursive Cramer-Rao lower bound and its velocity-constrained version.

[Huang2021] Appendix B.  Bearings ``beta = atan2(dy, dx)``, state
``[px, py, vx, vy]``.  Re-derived where the text is ambiguous:

* Eq. (B1)-(B5), Tichavsky's recursion with linear dynamics:
  ``J_{k+1} = D22 - D21 (J_k + D11)^-1 D12`` with ``D11 = F^T Q^-1 F``,
  ``D12 = -F^T Q^-1`` (the minus sign was lost), ``D21 = D12^T`` and
  ``D22 = Q^-1 + h^T h / sigma^2``.
* The measurement row: Appendix B writes the UB-PLKF row ``H_bar`` (divided by ``m``), but
  the Fisher information of a bearing ``beta + n`` is that of the bearing's gradient,
  ``h = [-sin beta, cos beta, 0, 0] / d``; with ``m`` the bound would change when the
  coordinate origin moves.  We use ``h``.
* ``J`` starts from the prior, ``J_1 = P0^-1 + h_1^T h_1 / sigma_1^2`` (the paper's
  "``J_0 = P_{0|-1}``" is the information ``P^-1``).  The gradients are taken on the
  given (deterministic) true track, as the paper evaluates it.
* Eq. (B6)-(B7), constrained bound with the speed constraint ``|A x|^2 = const``,
  ``A = [0, I]``: ``U = 2 x^T A^T A`` and
  ``J_C^-1 = J^-1 - J^-1 U^T (U J^-1 U^T)^-1 U J^-1``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["bearing_gradients", "constrained", "crlb", "rmse_bounds"]  # the public interface (docs/api.md)


def bearing_gradients(truth: np.ndarray, observer: np.ndarray) -> np.ndarray:
    """``d beta / d x`` (K, 4) for true states ``(K, 4)`` and observer positions ``(K, 2)``."""
    rel = truth[:, :2] - observer
    d2 = np.sum(rel**2, axis=1)
    h = np.zeros((len(truth), 4))
    h[:, 0], h[:, 1] = -rel[:, 1] / d2, rel[:, 0] / d2
    return h


def crlb(truth: np.ndarray, observer: np.ndarray, sigma: np.ndarray, f: np.ndarray, q: np.ndarray,
         p0: np.ndarray) -> np.ndarray:
    """Bounds ``J_k^-1`` (K, 4, 4) on the error covariance of any unbiased estimate of the
    state at scans k = 1..K, given bearings with std ``sigma (K,)`` (rad) from ``observer``.

    ``q`` is the truth's process noise: a positive definite ``Q`` for a truth that is
    random (the information form of Tichavsky et al.), or zeros for a deterministic truth
    (a known path: then ``J_k = F^-T J_{k-1} F^-1 + I_k``, the information of the start
    carried along; a simulated deterministic truth is bounded only by this one)."""
    h = bearing_gradients(truth, observer)
    info = h[:, :, None] * h[:, None, :] / np.broadcast_to(sigma, (len(truth),))[:, None, None] ** 2  # (K, 4, 4)
    j = np.linalg.inv(p0) + info[0]
    out = np.empty((len(truth), 4, 4))
    out[0] = np.linalg.inv(j)
    if not np.any(q):
        fi = np.linalg.inv(f)
        for k in range(1, len(truth)):
            j = fi.T @ j @ fi + info[k]
            out[k] = np.linalg.inv(j)
        return out
    qi = np.linalg.inv(q)
    d11, d12 = f.T @ qi @ f, -f.T @ qi
    for k in range(1, len(truth)):
        j = qi + info[k] - d12.T @ np.linalg.solve(j + d11, d12)
        out[k] = np.linalg.inv(j)
    return out


def constrained(bound: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Eq. (B6): the bound ``(K, 4, 4)`` restricted to the true speed's sphere
    ``|v|^2 = |v_k|^2`` with ``U = 2 [0, 0, vx, vy]``."""
    u = np.zeros((len(truth), 1, 4))
    u[:, 0, 2:] = 2 * truth[:, 2:]
    bu = bound @ np.swapaxes(u, 1, 2)  # (K, 4, 1)
    return bound - bu @ np.linalg.solve(u @ bu, np.swapaxes(bu, 1, 2))


def rmse_bounds(bound: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Position and velocity RMSE bounds (K,): square roots of the block traces."""
    return np.sqrt(bound[:, 0, 0] + bound[:, 1, 1]), np.sqrt(bound[:, 2, 2] + bound[:, 3, 3])
