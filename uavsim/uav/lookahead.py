"""The ``lookahead`` policy: a non-myopic UAV that rolls out the myopic one.

The paper's UAV ([Papaioannou2023] Eq. 13) looks one step ahead.  This policy
scores every admissible first move of Eq. (3) by the summed covariance traces of the
``horizon`` steps that follow when, after it, the UAV flies the myopic rule itself (a
rollout of the base policy, [Bertsekas2020, Ch. 2]): at every later step the admissible grid move of
Eq. (3) (area, operating region, obstacles, segments) of least summed trace after its
scan.  It flies the best first move and decides again the next step (receding horizon).
The myopic rule's own first move is among those scored, so the chosen move's score is
at most the score of flying the myopic rule throughout (in the model below; the measured
RMSE need not follow, see docs/results/lookahead.md).

**Score.**  Each target's predicted belief is summarised by its moments on
``[x, y, vx, vy]`` (:data:`uavsim.targets.HORIZONTAL`).  Along a path the covariance
follows the information recursion of the closed-loop bound, in covariance form
(:func:`uavsim.bounds.pcrlb.pcrlb_step`): ``P <- A P A^T + Q`` between scans, and a bearing scan
from the UAV's position ``s_k`` adds the information ``q2 h^T h / sigma^2`` on (x, y),
``h = (dy, -dx) / r^2``, with ``d`` the predicted mean minus ``s_k`` and ``q2`` the
information reduction factor of missed detections and clutter
(:meth:`uavsim.sensing.BearingModel.information`).  Under line of sight a scan from where a
predicted mean (on the ground) is hidden adds nothing.  The first step's term is Eq. (13)
itself, the belief's own pseudo-posterior traces (:meth:`uavsim.belief.Belief.traces`;
particles for the particle filter), so with ``horizon = 1`` the policy is ``optimized``;
the later terms come from the recursion, where one scan's trace is the rank-one update
``tr P - q2 |P E^T h|^2 / (sigma^2 + q2 h P_xy h^T)``.

**Predicted means.**  The linearisation points ``d`` are the targets' predicted means:
step 0 the belief's mean ``m_0``; later ones follow the guidance plan the filter predicts
with (:attr:`uavsim.guidance.Plan.means`, the ``forecast`` the simulation passes in):
``m_k = A^k m_0 + f_k`` with ``f_k = plan_k - A^k plan_0`` the plan's forced part (exact for
linear dynamics and the plan's controls, whatever the offset between ``m_0`` and
``plan_0``), and past the plan's end, or without a plan, ``f_k = A f_(k-1)`` (no force).

Choices (documented, not from a paper): the range in ``h`` is floored at 1 m (a UAV
directly above a mean).  Earlier versions scored straight continuations (stay, or the
largest move in one direction, repeated) with constant-velocity means; over 100 paired
trials they were up to 19% worse than ``optimized`` on a generated world: the best
straight continuation is an optimistic promise the next decision does not keep.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..belief.traces import MIN_RANGE_M, gaussian_traces
from ..bounds.pcrlb import pcrlb_step
from ..declare import setting
from ..mission import Mission
from ..targets import HORIZONTAL
from .grid import GridOptimizer, admissible, move_offsets


@dataclass(frozen=True, eq=False)
class LookaheadConfig:
    """``horizon``: steps scored per first move: the move, then ``horizon - 1`` steps of
    the myopic rule (1 = the first move only, the ``optimized`` policy)."""

    horizon: int = setting("horizon_steps", 6, lo=1, hi=50,
                           doc="steps scored per first move: the move, then the myopic rule (lookahead planner)")


class Lookahead(GridOptimizer):
    """Receding-horizon rollout of the myopic rule over grid moves (module docstring)."""

    name = "lookahead"

    def __init__(self, mission: Mission):
        super().__init__(mission)
        uav, dyn, s = mission.uav, mission.dynamics, mission.sensor
        self.horizon = mission.planner.lookahead.horizon
        off = move_offsets(uav.step, uav.n_theta, uav.n_r)  # (C, 2) the moves of Eq. (3)
        self.offsets = np.column_stack([off, np.zeros(len(off))])
        self.a = dyn.a[np.ix_(HORIZONTAL, HORIZONTAL)]
        self.q = dyn.q[np.ix_(HORIZONTAL, HORIZONTAL)]
        self.q2 = s.information_factor()

    def predicted_means(self, mean: np.ndarray, forecast: list | None = None) -> np.ndarray:
        """``(H, M, 4)`` predicted ``[x, y, vx, vy]`` means (module docstring) from the
        belief's ``mean (M, 6)`` and, per target, its plan's means ``(T, 6)`` or None."""
        out = np.empty((self.horizon, len(mean), 4))
        out[0] = mean[:, HORIZONTAL]
        for k in range(1, self.horizon):  # <= 50 steps of 4 x 4 products: not a hot loop
            out[k] = out[k - 1] @ self.a.T
        for j, plan in enumerate(forecast or []):
            if plan is None or not len(plan):
                continue
            free, forced = plan[0, HORIZONTAL], np.zeros(4)
            for k in range(1, self.horizon):
                free = self.a @ free
                forced = plan[k, HORIZONTAL] - free if k < len(plan) else self.a @ forced
                out[k, j] += forced
        return out

    def scan(self, cov: np.ndarray, centres: np.ndarray, at: np.ndarray, predict: bool = True) -> np.ndarray:
        """``(B, M, 4, 4)`` covariances ``cov (B, M, 4, 4)`` after one step (``predict``)
        and one scan from ``at (B, >=2)`` (:func:`pcrlb_step` with
        :meth:`uavsim.sensing.BearingModel.information`)."""
        a, q = (self.a, self.q) if predict else (np.eye(4), np.zeros((4, 4)))
        b, m = cov.shape[:2]
        info = self.sensor.information(centres, at[:, None, :], MIN_RANGE_M, self.seen(centres, at[:, None, :]))
        return pcrlb_step(cov.reshape(-1, 4, 4), a, q, info.reshape(-1, 2, 2)).reshape(b, m, 4, 4)

    def traces_after(self, pred: np.ndarray, centres: np.ndarray, at: np.ndarray) -> np.ndarray:
        """``(B, C)`` summed traces of predicted covariances ``pred (B, M, 4, 4)`` after a
        scan from each candidate ``at (B, C, >=2)``: Eq. (13) for Gaussian beliefs
        (:func:`gaussian_traces`) with the scan's noise variance ``sigma^2 / q2``."""
        if self.q2 == 0:  # no scan informs: the traces of the prediction
            return np.broadcast_to(np.trace(pred, axis1=-2, axis2=-1).sum(-1)[:, None], at.shape[:2])
        seen = self.seen(centres, at)
        return gaussian_traces(at, centres, pred, self.sensor, MIN_RANGE_M, self.q2,
                               None if seen is None else np.swapaxes(seen, -1, -2)).sum(-1)

    def seen(self, centres: np.ndarray, at: np.ndarray) -> np.ndarray | None:
        """``(..., M, C)`` 1.0 where the UAV at ``at (..., C, 3)`` sees the predicted means
        ``centres (M, 2)`` (taken on the ground), 0.0 where a building hides them; None
        without line of sight."""
        if not self.sensor.line_of_sight:
            return None
        ground = np.column_stack([centres, np.zeros(len(centres))])
        return self.sensor.visible(ground[:, None, :], at[..., None, :, :]).astype(float)

    def rollout(self, starts: np.ndarray, cov: np.ndarray, centres: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The myopic rule flown from each of ``starts (B, 3)`` for steps 1 .. H-1, with
        ``cov (B, M, 4, 4)`` the covariances after step 0's scan and ``centres (H, M, 2)``
        the predicted means.  Returns the summed traces ``(B,)`` and the paths ``(B, H, 3)``
        (``starts`` first).  Ties inside the rollout go to the lowest move index (the
        first move's are broken by :meth:`choose`); staying is always admissible where the UAV is."""
        rows = np.arange(len(starts))
        pos, total, path = starts, np.zeros(len(starts)), [starts]
        for k in range(1, self.horizon):  # <= 50 steps; branches, moves and targets are vectorised
            cands = pos[:, None, :] + self.offsets  # (B, C, 3)
            pred = self.a @ cov @ self.a.T + self.q
            tr = np.where(admissible(pos[:, None, :], cands, self.m.world, self.m.uav),
                          self.traces_after(pred, centres[k], cands), np.inf)
            pick = np.argmin(tr, axis=1)
            pos = cands[rows, pick]
            total += tr[rows, pick]
            cov = self.scan(pred, centres[k], pos, predict=False)
            path.append(pos)
        return total, np.stack(path, axis=1)

    def choose(self, belief, forecast: list | None = None) -> tuple[np.ndarray, np.ndarray, int]:
        """The candidates, each one's score (``inf``: not admissible) and the index of the
        best; ties are broken as Eq. (13)'s (:meth:`GridOptimizer.untie`).  ``forecast``: per
        target the means ``(T, 6)`` of the guidance plan the belief was predicted with."""
        cands, ok = self.moves()
        best = np.full(len(cands), np.inf)
        if ok.any():
            first = cands[ok]
            mean, cov = belief.moments()
            centres = self.predicted_means(mean, forecast)[..., :2]  # (H, M, 2)
            p0 = np.broadcast_to(cov[:, HORIZONTAL][:, :, HORIZONTAL], (len(first),) + (len(mean), 4, 4))
            later, _ = self.rollout(first, self.scan(p0, centres[0], first, predict=False), centres)
            best[ok] = belief.traces(first, self.sensor).sum(axis=1) + later  # Eq. (13), then the rollout
        return cands, best, self.untie(belief, forecast, cands, best, int(np.argmin(best)))

