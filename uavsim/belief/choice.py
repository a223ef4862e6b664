"""Which committed plan a particle flies: the one P1 would choose from its start.

With ``[filter] motion = "commit"`` a particle flies its cluster's plan plus the plan's
gains times its start's offset from the cluster's mean (:mod:`.particle`): an affine model
of P1's plan from its own start, exact while that plan keeps the cluster plan's faces and
active set.  A particle joins the cluster whose mean is nearest its start, and a start near
the edge of two routes (two ways round a block) often plans the other route: for about one
truth in two on the imported towns the nearest cluster's model strays more than 10 m from
the truth's plan within 20 steps (docs/results/towns.md, "Where the committed model misses
the truth").

Every cluster's model flown from a start is a plan from that start, and P1's plan is the
cheapest in Eq. (7) of the plans that keep clear [Papaioannou2023, Eq. (7)-(8)].  So with
``[filter] route_choice = "cheapest"`` a particle takes the cluster whose model from its
start costs least in Eq. (7),

    || p_T(d) - G_o ||^2 + rho sum_{t=1}^{T-1} || u_t(d) - u_{t-1}(d) ||^2   (+ rho || u_0(d) ||^2 with the link term),

among those whose positions at steps 2..T stay within :data:`CLEAR_TOL_M` of the clear
ground (the inflated obstacles' :class:`.world.space.DepthGrid` and the area), and its
nearest where none does; with ``"clear"`` it keeps its nearest cluster unless that model
runs into an obstacle, and only then takes the cheapest clear one.  ``p_t(d) = p_t + S_t
d`` and ``u_t(d) = u_t + K_t d`` are affine in the offset ``d``, so the cost is a
quadratic in ``d`` per cluster, formed once.  Speed and force limits are not checked
(an affine model that breaks them by a little is still the nearest thing to a plan with
that route), nor is a hard terminal region.  The tolerance allows for the models' small
excursions where the plan's active set changes within the offset (a model exactly on an
inflated face dips into it).

Measured (docs/results/towns.md, "A start's own route"): on the truths' starts the
cheapest clear model strays from the truth's plan less often than the nearest cluster's
(more than 10 m in 30-36 of 160 target-trials against 48-71), but the closed loop is no
better with either rule ("cheapest" moves most particles to a farther cluster, whose model
is worse away from its mean); the default stays "nearest".

Vectorised over particles and candidates; the one Python loop runs over the plan's steps.
"""

from __future__ import annotations

import numpy as np

from ..targets import HORIZONTAL, Dynamics

CLEAR_TOL_M = 3.0  # m: a candidate's model may dip this deep into the inflated obstacles (module docstring)


def cluster_models(means: np.ndarray, controls: np.ndarray, gains: np.ndarray, dynamics: Dynamics
                   ) -> tuple[np.ndarray, np.ndarray]:
    """``(states (K, T, 6), sens (K, T, 6, 4))``: each of K clusters' mean flown by its
    plan's ``controls (K, T, 3)``, and ``S_t = d x_t / d offset`` from its ``gains (K, T, 3,
    4)`` (``S_t = A S_{t-1} + B K_t``, ``S_{-1}`` the identity on ``[x, y, vx, vy]``), for
    steps 1..T."""
    k, t_len = controls.shape[:2]
    x, s = means.copy(), np.zeros((k, 6, 4))
    s[:, HORIZONTAL, np.arange(4)] = 1.0
    states, sens = np.empty((k, t_len, 6)), np.empty((k, t_len, 6, 4))
    for t in range(t_len):
        x = x @ dynamics.a.T + controls[:, t] @ dynamics.b.T
        s = dynamics.a @ s + dynamics.b @ gains[:, t]
        states[:, t], sens[:, t] = x, s
    return states, sens


def eq7_quadratic(states: np.ndarray, sens: np.ndarray, controls: np.ndarray, gains: np.ndarray, goal: np.ndarray,
                  rho: float, link: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Eq. (7)'s cost of each cluster's model from an offset ``d``, ``c + 2 g . d + d' H d``:
    ``(c (K,), g (K, 4), H (K, 4, 4))`` (see the module docstring for the terms)."""
    e, s_end = states[:, -1, :2] - goal[:2], sens[:, -1, :2]  # (K, 2), (K, 2, 4)
    du, dk = np.diff(controls[..., :2], axis=1), np.diff(gains[:, :, :2], axis=1)  # (K, T-1, 2), (K, T-1, 2, 4)
    if link:  # the first plan's step from zero force
        du = np.concatenate([controls[:, :1, :2], du], axis=1)
        dk = np.concatenate([gains[:, :1, :2], dk], axis=1)
    c = (e * e).sum(-1) + rho * (du * du).sum((1, 2))
    g = np.einsum("ki,kij->kj", e, s_end) + rho * np.einsum("kti,ktij->kj", du, dk)
    h = np.einsum("kij,kil->kjl", s_end, s_end) + rho * np.einsum("ktij,ktil->kjl", dk, dk)
    return c, g, h


def cheapest(starts: np.ndarray, order: np.ndarray, means: np.ndarray, states: np.ndarray, sens: np.ndarray,
             quad: tuple[np.ndarray, np.ndarray, np.ndarray], depth, keep: bool = False) -> np.ndarray:
    """``(N,)`` the cluster each of one target's ``starts (N, 6)`` flies: of its candidates
    ``order (N, C)`` (nearest first), the cheapest in Eq. (7) (``quad``, :func:`eq7_quadratic`)
    whose model (``states``, ``sens``: :func:`cluster_models` of the clusters' ``means (K,
    6)``) keeps within :data:`CLEAR_TOL_M` of the clear ground (``depth(points (..., 2))``,
    a :class:`.world.space.DepthGrid`), else its nearest.  ``keep``: its nearest is tried
    first, whatever it costs (``route_choice = "clear"``).

    The candidates are tried cheapest first, all particles at once: a round tests each
    undecided particle's next cheapest model at steps 2..T (step 1 is ``p + v dt``, which no
    force moves and P1 leaves out), so the loop runs over rounds, at most C."""
    n = len(starts)
    d = starts[:, None, HORIZONTAL] - means[None, :, HORIZONTAL]  # (N, K, 4)
    c, g, h = quad
    cost = c + 2.0 * np.einsum("ki,nki->nk", g, d) + np.einsum("nki,kij,nkj->nk", d, h, d)
    allowed = np.zeros(cost.shape, bool)
    np.put_along_axis(allowed, order, True, axis=1)
    cost = np.where(allowed, cost, np.inf)
    if keep:
        np.put_along_axis(cost, order[:, :1], -np.inf, axis=1)
    ranked = np.argsort(cost, axis=1, kind="stable")[:, :order.shape[1]]
    pos, to_pos = np.ascontiguousarray(states[:, 1:, :2]), np.ascontiguousarray(sens[:, 1:, :2])
    chosen, pending = order[:, 0].copy(), np.arange(n)
    for r in range(ranked.shape[1]):
        k = ranked[pending, r]
        tried = cost[pending, k] < np.inf
        pending, k = pending[tried], k[tried]
        if not len(pending):
            break
        p = pos[k] + np.einsum("ntij,nj->nti", to_pos[k], d[pending, k])
        clear = depth(p).max(axis=1) <= CLEAR_TOL_M
        chosen[pending[clear]] = k[clear]
        pending = pending[~clear]
    return chosen
