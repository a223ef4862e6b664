"""The ``lookahead`` policy: a non-myopic UAV that scores whole paths of grid moves.

The paper's UAV (004_22b452551a772073.txt Eq. 13) looks one step ahead.  This policy
scores every admissible first move of Eq. (3) followed by ``horizon - 1`` steps of one
straight continuation (staying, or the largest grid move ``N_r Dr`` in one of the
``N_th`` grid directions, repeated), and flies the first move of the best path; the
next step it decides again (receding horizon).  A path stops (stays put) at its last
position before one that, like a single move in Eq. (3), leaves the area or the
operating region, lies in an obstacle or is reached through one.  (Pruning such paths
instead, the first version, left little but "stay" near the area's edges.)

**Score.**  Each target's predicted belief is summarised by its moments on
``[x, y, vx, vy]`` (:data:`uavsim.targets.HORIZONTAL`).  Along a path the covariance
follows the information recursion of the closed-loop bound, in covariance form
(:func:`uavsim.pcrlb.pcrlb_step`): ``P <- A P A^T + Q`` between scans, and a bearing scan
from the UAV's position ``s_k`` adds the information ``q2 h^T h / sigma^2`` on (x, y),
``h = (dy, -dx) / r^2``, with ``d`` the predicted mean minus ``s_k`` and ``q2`` the information reduction factor
of missed detections and clutter (:func:`uavsim.pcrlb.information_reduction_factor`).
The path's score is ``sum_k sum_j tr P_{j,k}`` over its ``horizon`` steps: the Eq. (13)
criterion (summed covariance traces) accumulated over the path instead of taken once.
The first step's term is Eq. (13) itself, the belief's own pseudo-posterior traces
(:meth:`uavsim.belief.Belief.traces`; particles for the particle filter), so with
``horizon = 1`` the policy is ``optimized``; the later terms come from the recursion.

Choices (documented, not from a paper): the predicted means move at constant velocity
(``p <- p + dt v``; the targets' guidance forces are not known to the UAV), the range in
``h`` is floored at 1 m (a UAV directly above a mean), and continuations are straight
so that the number of paths is ``C (1 + N_th)``, not ``C^horizon``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..mission import Mission
from ..pcrlb import information_reduction_factor, pcrlb_step
from ..targets import HORIZONTAL
from .grid import GridOptimizer, move_offsets

MIN_RANGE_M = 1.0


@dataclass(frozen=True, eq=False)
class LookaheadConfig:
    """``horizon``: steps scored per path (1 = the first move only)."""

    horizon: int = 16


class Lookahead(GridOptimizer):
    """Receding-horizon path search over grid moves (module docstring)."""

    name = "lookahead"

    def __init__(self, mission: Mission):
        super().__init__(mission)
        uav, dyn, s = mission.uav, mission.dynamics, mission.sensor
        self.horizon = mission.planner.lookahead.horizon
        ring = move_offsets(uav.n_r * uav.step, uav.n_theta, 1)  # (1 + N_th, 2): stay, then the largest moves
        self.continuations = ring
        self.a = dyn.a[np.ix_(HORIZONTAL, HORIZONTAL)]
        self.q = dyn.q[np.ix_(HORIZONTAL, HORIZONTAL)]
        self.dt = dyn.dt
        self.gain = information_reduction_factor(s.sigma, s.p_detect, s.clutter_rate) / s.sigma**2  # q2 / sigma^2

    def paths(self, cands: np.ndarray) -> np.ndarray:
        """``(C, V, H, 3)`` positions: first move c, then continuation v repeated."""
        k = np.arange(self.horizon)[None, None, :, None]
        xy = cands[:, None, None, :2] + k * self.continuations[None, :, None, :]
        z = np.broadcast_to(cands[:, None, None, 2:], xy.shape[:-1] + (1,))
        return np.concatenate([xy, z], axis=-1)

    def stop_at_limits(self, paths: np.ndarray) -> np.ndarray:
        """``paths (C, V, H, 3)`` with every position from the first inadmissible one on
        (outside the area or region, in an obstacle, or reached through one) replaced by
        the last admissible one: the UAV stops there.  The first move is checked by
        :meth:`moves`."""
        w, region = self.m.world, self.m.uav.region
        later = paths[:, :, 1:]
        ok = w.in_area(later) & ~w.in_obstacle(later) & ~w.segment_blocked(paths[:, :, :-1], later)
        if region is not None:
            ok &= region.contains(later)
        last = np.logical_and.accumulate(ok, axis=-1).sum(axis=-1)  # (C, V) admissible steps after the first
        idx = np.minimum(np.arange(paths.shape[2]), last[..., None])  # (C, V, H)
        return np.take_along_axis(paths, idx[..., None], axis=2)

    def scores(self, paths: np.ndarray, mean: np.ndarray, cov: np.ndarray, first: int = 0) -> np.ndarray:
        """``(P,)`` summed covariance traces along ``paths (P, H, >=2)`` for beliefs
        ``mean (M, 6)``, ``cov (M, 6, 6)`` (module docstring), from step ``first`` on."""
        m0 = mean[:, HORIZONTAL]  # (M, 4)
        n, m = len(paths), len(mean)
        p = np.broadcast_to(cov[:, HORIZONTAL][:, :, HORIZONTAL], (n, m, 4, 4)).reshape(-1, 4, 4)
        still = (np.eye(4), np.zeros((4, 4)))  # step 0: the belief is already predicted
        total = np.zeros(n)
        for k in range(self.horizon):  # horizon <= a few tens: the paths, targets and states are vectorised
            centre = m0[:, :2] + k * self.dt * m0[:, 2:]  # (M, 2) constant-velocity mean
            d = centre[None, :, :] - paths[:, k, None, :2]  # (P, M, 2)
            h = np.stack([d[..., 1], -d[..., 0]], -1) / np.maximum((d**2).sum(-1), MIN_RANGE_M**2)[..., None]
            info = self.gain * h[..., :, None] * h[..., None, :]  # (P, M, 2, 2) q2 h^T h / sigma^2
            p = pcrlb_step(p, *((self.a, self.q) if k else still), info.reshape(-1, 2, 2))
            if k >= first:
                total += np.trace(p, axis1=1, axis2=2).reshape(n, m).sum(axis=1)
        return total

    def choose(self, belief) -> tuple[np.ndarray, np.ndarray, int]:
        """The candidates, each one's best path score (``inf``: no admissible path) and the
        index of the best; ties go to the lowest index, as in Eq. (13)."""
        cands, ok = self.moves()
        best = np.full(len(cands), np.inf)
        if ok.any():
            paths = self.stop_at_limits(self.paths(cands[ok]))  # (C', V, H, 3)
            mean, cov = belief.moments()
            now = belief.traces(cands[ok], self.sensor.sigma).sum(axis=1)  # (C',) Eq. (13) itself
            later = self.scores(paths.reshape(-1, *paths.shape[2:]), mean, cov, 1).reshape(paths.shape[:2])
            best[ok] = now + later.min(axis=1)
        return cands, best, int(np.argmin(best))
