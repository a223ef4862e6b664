"""Equality constraints on a state estimate, batched over runs ([Li2022, Sec. 3-4]).

[Li2022]: the mean-square method (Eq. 25-32) and the estimate projection
(Eq. 33-38) for linear constraints ``G x = g`` (Simon & Chia, its ref. [33]); the linear
approximation (Eq. 40-42) and the second-order approximation (Eq. 43-63, Yang & Blasch,
its ref. [34]) for a scalar nonlinear constraint ``h(x) = q`` (Eq. 39); the arc's
tangent-velocity constraint (Eq. 81-83).

Estimates ``x (R, n)``, covariances ``P (R, n, n)``.  Every method is a pure function
returning ``(x~, ok)``; where ``ok (R,)`` is False the constraint could not be applied
(a singular projection, no root of the multiplier equation) and the run keeps ``x``.
The callables :class:`LinearProjection`, :class:`NonlinearProjection`,
:class:`TangentVelocity` and :class:`Chain` wrap them as ``(x, P) -> (x~, ok)`` for
:class:`.plmmse.PseudoLinearGM`.

Re-derived where the print is garbled or less general than the scenarios need:

* Eq. (41)-(42): the print writes ``g`` for ``q``; (42) is the ``W = I`` projection onto
  the tangent plane, ``x~ = x^ - h'^T (h' h'^T)^-1 (h(x^) - q)``; we also allow ``W = P^-1``.
* Eq. (44)-(46) are the second-order Taylor expansion of ``h - q`` about ``x^``.  We write
  it in the shifted variable ``d = x - x^``: ``M = h''/2``, ``m = h'^T / 2``,
  ``m0 = h(x^) - q``, the same quadric as (43) without the cancellation of (45)-(46)'s
  absolute form (positions of 200 m against corrections of 1e-4 m on the slow arc).
* Eq. (52)-(54) factor ``M = L^T L`` by Cholesky, which needs ``M`` positive definite
  (a circle on a 4-D state has the singular ``M = diag(1, 1, 0, 0)``).  We use the
  equivalent symmetric eigen-decomposition ``E^-T M E^-1 = V diag(d_i) V^T`` with
  ``H^T H = E^T E`` (``E`` upper triangular; the print's "upper right diagonal"): for a
  positive definite ``M`` it is the SVD of (54) with ``d_i = p_i^2``, and it also holds
  for a semi-definite or indefinite ``M``.  (55)-(60) then read with ``p_i^2 -> d_i``.
* Eq. (61)-(62): the print writes ``sigma_i^2`` for ``p_i^2`` and ``G`` for ``E``;
  ``e_dot = -t``.  With ``y_i = e_i / (1 + lambda d_i)`` the derivative simplifies to
  ``f'(lambda) = -2 sum_i (d_i y_i + t_i)^2 / (1 + lambda d_i)``: on the interval where
  every ``1 + lambda d_i > 0`` (where ``x~(lambda)`` minimises the Lagrangian) ``f`` is
  strictly decreasing, so the root there is unique.  Newton's iteration (63) starts at
  ``lambda = 0`` as printed; a step that leaves the bracket is replaced by bisection
  (our safeguard), and it stops at ``|d lambda| <= tol |lambda|`` (relative, where the
  print's ``tau`` is absolute) or after ``max_iter`` steps.
* Eq. (83): ``theta = atan2(y - R_y, x - R_x)``, the angle about the turning centre, is
  the direction normal to the circle; the print's ``tan^-1(x(2) / x(1))`` measures it
  about the origin (``about="origin"`` gives that literal reading).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from .plkf import POS, VEL


def _check(name: str, value: str, allowed: tuple[str, ...]) -> None:
    if value not in allowed:
        raise ValueError(f"{name} must be one of {', '.join(allowed)}, got {value!r}")


def _project(x, g_mat, resid, p=None):
    """``x - A G^T (G A G^T)^-1 resid`` with ``A = I`` or ``P``; ``g_mat (R, d, n)``."""
    a_gt = np.swapaxes(g_mat, 1, 2) if p is None else p @ np.swapaxes(g_mat, 1, 2)
    s = g_mat @ a_gt
    ev = np.linalg.eigvalsh(s)
    ok = np.isfinite(ev).all(axis=1) & (ev[:, 0] > 1e-12 * np.maximum(ev[:, -1], 1e-300))
    out = x.copy()
    if ok.any():
        lam = np.linalg.solve(s[ok], resid[ok][:, :, None])  # Eq. (32), (38)
        out[ok] = x[ok] - (a_gt[ok] @ lam)[:, :, 0]
    return out, ok


def project_linear(x, g_mat, g, p=None):
    """Eq. (31) (mean square, ``W = I``, ``p`` None) or Eq. (37) (estimate projection,
    ``W = P^-1``): ``x~ = x - W^-1 G^T (G W^-1 G^T)^-1 (G x - g)`` for ``G (d, n)`` or
    ``(R, d, n)`` of full row rank and ``g (d,)`` or ``(R, d)``.  Returns ``(x~, ok)``."""
    r = x.shape[0]
    g_mat = np.broadcast_to(np.asarray(g_mat, float), (r, *np.shape(g_mat)[-2:]))
    resid = np.einsum("rdn,rn->rd", g_mat, x) - np.broadcast_to(g, (r, g_mat.shape[1]))
    return _project(x, g_mat, resid, p)


@dataclass(frozen=True)
class ScalarConstraint:
    """``h(x) = q`` (Eq. 39), batched: ``h (R, n) -> (R,)``, ``jac -> (R, n)``, ``hess -> (R, n, n)``."""

    h: Callable[[np.ndarray], np.ndarray]
    jac: Callable[[np.ndarray], np.ndarray]
    hess: Callable[[np.ndarray], np.ndarray]
    q: float


def circle(centre, radius: float, n: int = 4, pos=POS) -> ScalarConstraint:
    """Eq. (76)-(77): ``h(x) = (x(1) - R_x)^2 + (x(2) - R_y)^2 = R^2`` on the position."""
    c, idx = np.asarray(centre, float), list(pos)
    hess = np.zeros((n, n))
    hess[idx, idx] = 2.0

    def jac(x):
        j = np.zeros_like(x)
        j[:, idx] = 2 * (x[:, idx] - c)
        return j

    return ScalarConstraint(h=lambda x: np.sum((x[:, idx] - c) ** 2, axis=1), jac=jac,
                            hess=lambda x: np.broadcast_to(hess, (x.shape[0], n, n)), q=float(radius) ** 2)


def linear_approximation(x, con: ScalarConstraint, p=None):
    """Eq. (40)-(42): project onto the tangent plane ``h'(x^) x = q - h(x^) + h'(x^) x^``
    (``W = I``, as printed, or ``W = P^-1``).  Returns ``(x~, ok)``."""
    return _project(x, con.jac(x)[:, None, :], (con.h(x) - con.q)[:, None], p)


def second_order_terms(x, con: ScalarConstraint):
    """Eq. (44)-(46) in the shifted variable ``d = x - x^`` (module docstring):
    ``M = h''(x^) / 2 (R, n, n)``, ``m = h'(x^)^T / 2 (R, n)``, ``m0 = h(x^) - q (R,)``."""
    return con.hess(x) / 2, con.jac(x) / 2, con.h(x) - con.q


def _secular(d, a, t, m0, lam):
    """Eq. (60) and the re-derived (61): ``f(lambda)``, ``f'(lambda)`` and ``y = (I + lambda D)^-1 e``."""
    den = 1 + lam[:, None] * d
    y = (a - lam[:, None] * t) / den  # e(lambda) = e(0) - lambda t, Eq. (55), (62)
    f = np.sum(d * y**2 + 2 * t * y, axis=1) + m0
    fp = -2 * np.sum((d * y + t) ** 2 / den, axis=1)
    return f, fp, y


def _bracket(d):
    """The interval of ``lambda`` where every ``1 + lambda d_i > 0``."""
    with np.errstate(divide="ignore"):
        inv = -1.0 / d
    lo = np.max(np.where(d > 0, inv, -np.inf), axis=1)
    hi = np.min(np.where(d < 0, inv, np.inf), axis=1)
    return lo, hi


def _factor(h_mat, big_m):
    """Eq. (52)-(54) re-derived: ``E^-1`` with ``H^T H = E^T E`` and ``E^-T M E^-1 = V diag(d) V^T``.
    Factored once when every run has the same ``H`` and ``M`` (a quadric with ``W = I``)."""
    if len(big_m) > 1 and (big_m == big_m[:1]).all() and (h_mat == h_mat[:1]).all():
        return tuple(np.broadcast_to(a, (len(big_m), *a.shape[1:])) for a in _factor(h_mat[:1], big_m[:1]))
    e_inv = np.linalg.inv(np.swapaxes(np.linalg.cholesky(np.swapaxes(h_mat, 1, 2) @ h_mat), 1, 2))
    d, v = np.linalg.eigh(np.swapaxes(e_inv, 1, 2) @ big_m @ e_inv)
    return e_inv, v, d


def quadric_lsq(h_mat, z, big_m, m, m0, tol: float = 1e-12, max_iter: int = 60):
    """Eq. (47)-(63): ``argmin |z - H x|^2`` subject to ``x^T M x + 2 m^T x + m0 = 0``.

    ``H (R, k, n)`` of full column rank, ``z (R, k)``, ``M (R, n, n)`` symmetric (any
    inertia), ``m (R, n)``, ``m0 (R,)``.  Returns ``x~ (R, n)``, the multiplier
    ``lambda (R,)`` and ``ok (R,)`` (False where Newton's iteration found no root inside
    the bracket; ``x~`` is then the unconstrained solution)."""
    e_inv, v, d = _factor(h_mat, big_m)
    ev_t = np.swapaxes(e_inv @ v, 1, 2)  # V^T E^-T
    a = (ev_t @ (np.swapaxes(h_mat, 1, 2) @ z[:, :, None]))[:, :, 0]  # e(0), Eq. (55)
    t = (ev_t @ m[:, :, None])[:, :, 0]  # Eq. (56)
    lam, (lo, hi) = np.zeros(len(m0)), _bracket(d)
    active, failed = np.ones(len(m0), bool), np.zeros(len(m0), bool)
    for _ in range(max_iter):
        f, fp, _ = _secular(d, a, t, m0, lam)
        lo, hi = np.where(f > 0, lam, lo), np.where(f < 0, lam, hi)  # f decreases through the root
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            new = lam - f / fp  # Eq. (63)
            new = np.where((new > lo) & (new < hi), new, 0.5 * (lo + hi))  # safeguard: bisect
        failed |= active & ~np.isfinite(new)  # an unbounded bracket and no sign change: no root
        done = (f == 0) | (np.abs(new - lam) <= tol * np.abs(new))
        lam = np.where(active & ~failed, new, lam)
        active &= ~done & ~failed
        if not active.any():
            break
    _, _, y = _secular(d, a, t, m0, lam)
    ok = ~active & ~failed
    x = (np.swapaxes(ev_t, 1, 2) @ np.where(ok[:, None], y, a)[:, :, None])[:, :, 0]  # Eq. (57)
    return x, np.where(ok, lam, 0.0), ok


def second_order(x, con: ScalarConstraint, p=None, tol: float = 1e-12, max_iter: int = 60):
    """Table 3 step 5: the second-order approximation of ``h(x) = q`` about ``x^``
    (Eq. 44-46) and the projection (47) onto it, ``W = I`` (``p`` None, the paper's
    ``z = x^``, ``H = I``) or ``W = P^-1`` (``H = L^-1`` with ``P = L L^T``).  Exact for a
    quadric ``h``.  Returns ``(x~, ok)``."""
    r, n = x.shape
    big_m, m, m0 = second_order_terms(x, con)
    h_mat = np.broadcast_to(np.eye(n), (r, n, n)) if p is None else np.linalg.inv(np.linalg.cholesky(p))
    dx, _, ok = quadric_lsq(h_mat, np.zeros((r, n)), big_m, m, m0, tol, max_iter)
    return x + dx, ok


def tangent_velocity(x, centre, about: str = "centre", pos=POS, vel=VEL):
    """Eq. (81)-(83): ``v~ = (v^ . mu) mu`` with ``mu = [-sin theta, cos theta]`` and
    ``theta`` the position's angle about the turning centre (``about="origin"``: the
    printed ``tan^-1(x(2)/x(1))``).  Returns ``(x~, ok)``."""
    _check("about", about, ("centre", "origin"))
    rel = x[:, list(pos)] - (np.asarray(centre, float) if about == "centre" else 0.0)
    theta = np.arctan2(rel[:, 1], rel[:, 0])
    mu = np.stack([-np.sin(theta), np.cos(theta)], -1)
    out = x.copy()
    out[:, list(vel)] = np.einsum("ri,ri->r", x[:, list(vel)], mu)[:, None] * mu
    return out, np.any(rel != 0, axis=1)


@dataclass(frozen=True)
class LinearProjection:
    """Table 2 step 5: ``G x = g`` by ``W = I`` (``weight="I"``, Eq. 31) or ``W = P^-1`` (Eq. 37)."""

    g_mat: np.ndarray
    g: np.ndarray
    weight: str = "I"

    def __post_init__(self):
        _check("weight", self.weight, ("I", "P"))

    def __call__(self, x, p):
        return project_linear(x, self.g_mat, self.g, p if self.weight == "P" else None)


@dataclass(frozen=True)
class NonlinearProjection:
    """Eq. (42) (``method="linear"``) or Table 3 step 5 (``"second-order"``) for ``h(x) = q``."""

    con: ScalarConstraint
    method: str = "linear"
    weight: str = "I"

    def __post_init__(self):
        _check("method", self.method, ("linear", "second-order"))
        _check("weight", self.weight, ("I", "P"))

    def __call__(self, x, p):
        w = p if self.weight == "P" else None
        if self.method == "linear":
            return linear_approximation(x, self.con, w)
        return second_order(x, self.con, w)


@dataclass(frozen=True)
class TangentVelocity:
    """Eq. (81)-(83) as a constraint callable."""

    centre: tuple[float, float]
    about: str = "centre"

    def __post_init__(self):
        _check("about", self.about, ("centre", "origin"))

    def __call__(self, x, p):
        return tangent_velocity(x, self.centre, self.about)


@dataclass(frozen=True)
class Chain:
    """Constraints applied in order (the arc: position, then velocity); ``ok`` where all applied."""

    steps: tuple

    def __call__(self, x, p):
        ok = np.ones(x.shape[0], bool)
        for step in self.steps:
            x, ok_step = step(x, p)
            ok &= ok_step
        return x, ok
