"""The UAV's grid moves and the decision rule that picks one (the ``optimized`` policy).

[Papaioannou2023] Eq. (3): from ``s_{t-1}`` the UAV may move to::

    (s_x + lam Dr cos(kap Dth), s_y + lam Dr sin(kap Dth), h),
    lam in {0..N_r}, kap in {1..N_th}, Dth = 2 pi / N_th

(move angles measured from +x, counter-clockwise, exactly as Eq. (3) writes them).
``lam = 0`` is one "stay" candidate, so there are ``1 + N_r N_th`` distinct positions.
A candidate is admissible when it lies in the area and the operating region, outside
every obstacle, and the straight segment to it crosses no obstacle (Sec. V-B, last
paragraph; a crossing move is as bad as one that ends inside).  The ``optimized`` policy
(Sec. V-B) goes to the admissible candidate of least summed pseudo-posterior covariance
trace, Eq. (13) (:func:`decide`), the traces asked of the belief (Eq. 12,
:meth:`uavsim.belief.Belief.traces`).  The ``weighted`` policy (:class:`Weighted`, ours)
weighs each target's trace by its largest over the moves (about its trace with no useful
bearing): a target the UAV knows little about counts for more, so it is revisited sooner,
while every other target still counts (the largest trace alone did better on two towns of
three and worse on the third, docs/results/towns.md).  The ``seek`` policy (:class:`Seek`,
ours) flies to a target the myopic rule cannot see, when that pays more per step.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..declare import SettingError, setting
from ..mission import Mission
from ..world import Region2D, World

TIE_RTOL = 1e-9  # summed traces this close (relative) tie in Eq. (13): the same up to rounding


@dataclass(frozen=True, eq=False)
class UavConfig:
    """UAV grid motion Eq. (3) and where it may fly.

    Attributes
    ----------
    start : (3,) m; step : Delta_r (m); n_theta, n_r : grid sizes; altitude : h (m);
    region : optional operating region (Sec. VI-B "allowed sub-region");
    random_start : each trial draws the start uniformly in the region (or the area) at
        altitude h, outside obstacles (Sec. VI-B); otherwise every trial starts at ``start``.
    """

    region: Region2D | None = None  # read by the config module from [uav.operating_region]
    start: np.ndarray = setting("start_m", kind="array", unit="m", shape=(3,),
                                derived="(0.15, 0.2) of the operating region (or area), at altitude_m",
                                doc="the UAV's start when random_start is false")
    step: float = setting("step_m", 5.0, unit="m", lo=0.01, hi=1000,
                          doc="Delta_r, the grid's ring spacing (Eq. 3)")
    n_theta: int = setting("n_theta", 15, lo=1, hi=360, doc="N_theta, move directions (Eq. 3)")
    n_r: int = setting("n_r", 4, lo=1, hi=100, doc="N_r, rings of moves (Eq. 3)")
    altitude: float = setting("altitude_m", kind="number", unit="m", lo=0.1, hi=1e5,
                              derived="40 m, or half the area's height if that is lower",
                              doc="h, the UAV's flight altitude, within the area's height")
    random_start: bool = setting("random_start", True,
                                 doc="each trial draws the start uniformly in the region at altitude_m (Sec. VI-B)")


def move_offsets(step: float, n_theta: int, n_r: int) -> np.ndarray:
    """``(1 + n_r * n_theta, 2)`` planar offsets of Eq. (3); row 0 is "stay".

    Rows run over lam = 1..n_r (outer) and kap = 1..n_theta (inner).
    """
    lam = np.arange(1, n_r + 1)[:, None]
    ang = 2.0 * np.pi * np.arange(1, n_theta + 1)[None, :] / n_theta
    ring = np.stack([lam * step * np.cos(ang), lam * step * np.sin(ang)], axis=-1).reshape(-1, 2)
    return np.vstack([np.zeros((1, 2)), ring])


def candidates(position: np.ndarray, uav: UavConfig) -> np.ndarray:
    """``(C, 3)`` candidate next positions of Eq. (3) from ``position (3,)`` at altitude h."""
    off = move_offsets(uav.step, uav.n_theta, uav.n_r)
    xy = position[:2] + off
    return np.column_stack([xy, np.full(len(off), uav.altitude)])


def admissible(position: np.ndarray, cands: np.ndarray, world: World, uav: UavConfig) -> np.ndarray:
    """``(C,)`` bool: candidate is in the area and region, not in nor through an obstacle."""
    ok = world.in_area(cands) & ~world.in_obstacle(cands) & ~world.segment_blocked(position, cands)
    if uav.region is not None:
        ok &= uav.region.contains(cands)
    return ok


def uav_start(rng: np.random.Generator, uav: UavConfig, world: World, tries: int = 10_000) -> np.ndarray:
    """The UAV's start: the mission's, or uniform in the region (area) at altitude h,
    outside obstacles (rejection sampling, in batches; fixed draw count per batch)."""
    if not uav.random_start:
        return uav.start.copy()
    lo, hi = world.area_lo[:2], world.area_hi[:2]
    if uav.region is not None:
        lo, hi = np.maximum(lo, uav.region.vertices.min(0)), np.minimum(hi, uav.region.vertices.max(0))
    for _ in range(tries // 100):
        p = np.column_stack([rng.uniform(lo, hi, (100, 2)), np.full(100, uav.altitude)])
        ok = ~world.in_obstacle(p) & (uav.region.contains(p) if uav.region is not None else True)
        if ok.any():
            return p[np.argmax(ok)]
    raise SettingError("uav.random_start",
                       f"no free start found in {tries} draws: the operating region is (nearly) all obstacle")


def decide(candidates: np.ndarray, admissible: np.ndarray, traces, weighted: bool = False
           ) -> tuple[int, np.ndarray]:
    """Eq. (13): index of the admissible candidate with the least summed trace (ties go
    to the lowest index, row 0 "stay"; the policies then break them,
    :meth:`GridOptimizer.untie`), and the summed traces ``(C,)`` (``inf`` for
    inadmissible candidates).  ``traces(candidates)``
    gives ``(C, M)``: :func:`uavsim.belief.traces.pseudo_traces` or
    :func:`~uavsim.belief.traces.gaussian_traces` bound to the beliefs.

    ``weighted`` (the ``weighted`` policy): each target's trace counts in proportion to
    its largest over the admissible moves (about its trace with no useful bearing), those
    weights scaled to mean 1; the scores are the weighted sums."""
    total = np.full(len(candidates), np.inf)
    if admissible.any():
        t = traces(candidates[admissible])
        if weighted:
            w = t.max(axis=0)
            t = t * (w / w.mean()) if w.mean() > 0 else t  # all zero: nothing to weigh
        total[admissible] = t.sum(axis=1)
    return int(np.argmin(total)), total


def ties(scores: np.ndarray, best: int) -> np.ndarray:
    """``(C,)`` bool: the moves whose ``scores (C,)`` tie with ``scores[best]`` (:data:`TIE_RTOL`)."""
    return np.isclose(scores, scores[best], rtol=TIE_RTOL, atol=0.0)


def every_move_ties(scores: np.ndarray | None) -> bool:
    """True when two or more moves are admissible (``scores (C,)`` finite) and all tie: no
    move's scan would tell more than another's (under line of sight, none sees a target)."""
    if scores is None or np.isfinite(scores).sum() < 2:
        return False
    return bool(ties(scores, int(np.argmin(scores)))[np.isfinite(scores)].all())


def nearest(cands: np.ndarray, among: np.ndarray, goal: np.ndarray) -> int:
    """Index of the candidate ``cands (C, 3)`` marked in ``among (C,)`` nearest ``goal (2,)``."""
    return int(np.argmin(np.where(among, np.hypot(*(cands[:, :2] - goal).T), np.inf)))


class OneUav:
    """A policy flying one UAV with the mission's sensor from ``position (3,)``."""

    def __init__(self, mission: Mission):
        self.m, self.sensor = mission, mission.sensor
        self.position = mission.uav.start.copy()

    def reset(self, rng: np.random.Generator) -> None:
        self.position = uav_start(rng, self.m.uav, self.m.world)

    @property
    def observers(self) -> np.ndarray:
        return self.position[None, :]

    @property
    def uav(self) -> np.ndarray:
        return self.position


class GridOptimizer(OneUav):
    """The ``optimized`` policy: one grid move per step, chosen by Eq. (13) or given."""

    name = "optimized"
    weighted = False  # Eq. (13)'s sum of the targets' traces (True: weighted by their size, :class:`Weighted`)

    def moves(self) -> tuple[np.ndarray, np.ndarray]:
        """The candidate positions ``(C, 3)`` and which are admissible ``(C,)``."""
        cands = candidates(self.position, self.m.uav)
        return cands, admissible(self.position, cands, self.m.world, self.m.uav)

    def scored(self, belief) -> tuple[np.ndarray, np.ndarray, int]:
        """Eq. (13) on the predicted ``belief``: the candidates, their summed traces
        (``inf``: not admissible) and the index of the best, ties unbroken."""
        cands, ok = self.moves()
        best, scores = decide(cands, ok, lambda c: belief.traces(c, self.sensor), self.weighted)
        return cands, scores, best

    def choose(self, belief, forecast: list | None = None) -> tuple[np.ndarray, np.ndarray, int]:
        """:meth:`scored`, its ties broken by :meth:`untie`.  ``forecast`` (the targets'
        plans, see :meth:`act`) is not needed one step ahead."""
        cands, scores, best = self.scored(belief)
        return cands, scores, self.untie(belief, forecast, cands, scores, best)

    def untie(self, belief, forecast: list | None, cands: np.ndarray, scores: np.ndarray, best: int,
              flight: tuple | None = None) -> int:
        """``best``, or where several admissible moves tie with it (``scores (C,)`` within
        :data:`TIE_RTOL`), the tied move nearest the point of :meth:`flight` when that
        flight gains and is longer than one step (module docstring).  ``flight``: what
        :meth:`flight` returned this step, if the caller has it."""
        if not np.isfinite(scores[best]):
            return best
        tied = ties(scores, best)
        if tied.sum() < 2:
            return best
        rate, steps, goal, _ = flight or self.flight(belief, forecast)
        if rate <= 0 or steps <= 1:
            return best
        return nearest(cands, tied, goal)

    def flight(self, belief, forecast: list | None = None) -> tuple[float, float, np.ndarray, float]:
        """The best flight to a target's vantage (:class:`Seek`): the summed trace its bearing
        removes per step of the flight ``g_j / s_j``, the steps ``s_j``, the point to head for
        ``(2,)`` (where the target's ``forecast`` puts it on arrival, else its predicted mean)
        and the summed trace with no scan ``T``."""
        mean, cov = belief.moments()
        total = float(np.trace(cov, axis1=1, axis2=2).sum())
        away = mean[:, :2] - self.position[:2]
        dist = np.hypot(*away.T)
        short = np.clip(1.0 - self.m.uav.step / np.maximum(dist, 1e-9), 0.0, None)[:, None]
        vantage = np.column_stack([self.position[:2] + short * away, np.full(len(mean), self.m.uav.altitude)])
        steps = np.maximum(1, np.ceil((dist - self.m.uav.step) / (self.m.uav.n_r * self.m.uav.step)))
        rate = (total - belief.traces(vantage, self.sensor).sum(axis=1)) / steps
        j = int(np.argmax(rate))
        goal = mean[j, :2]
        if forecast is not None and forecast[j] is not None:
            goal = forecast[j][min(int(steps[j]), len(forecast[j]) - 1), :2]
        return float(rate[j]), float(steps[j]), goal, total

    def act(self, t: int, belief, action: int | None = None, forecast: list | None = None
            ) -> tuple[np.ndarray, np.ndarray | None]:
        """Move: to candidate ``action`` if given (it must be admissible), else by
        :meth:`choose` (staying put when no move is admissible).  Returns the candidates
        and, when the rule chose, their scores.  ``forecast``: per target the means
        ``(T, 6)`` of the guidance plan the belief was predicted with, or None."""
        if action is not None:
            cands, ok = self.moves()
            if not (0 <= action < len(cands) and ok[action]):
                raise ValueError(f"move {action} is not admissible here")
            self.position = cands[action]
            return cands, None
        cands, scores, best = self.choose(belief, forecast)
        if np.isfinite(scores[best]):
            self.position = cands[best]
        return cands, scores


class Seek(GridOptimizer):
    """The ``seek`` policy (ours): Eq. (13)'s move, unless flying to a target pays more.

    A bearing from target j's *vantage* ``v_j`` (one ring step ``Dr`` short of its predicted
    mean on the UAV's side, at altitude h: not right above it, where a bearing is undefined)
    would lower the summed trace by ``g_j = T - sum_k tr(Sigma~_k(v_j))``, ``T`` the summed
    trace with no scan (:meth:`uavsim.belief.Belief.moments`); reaching it takes ``s_j =
    ceil(|v_j - s| / (N_r Dr))`` steps.  When the best ``g_j / s_j`` exceeds what Eq. (13)'s
    move gains now, ``T - min_s sum_k tr(Sigma~_k(s))``, and ``v_j`` is more than one step
    away, the UAV takes the admissible move nearest the point the target's forecast puts it
    at on arrival (its predicted mean where there is no forecast).  A target far off, or
    hidden by buildings under line of sight, adds about the same to every candidate of
    Eq. (13), so the myopic rule does not go to it; this one does, once what it would learn
    there per step of the flight beats what it learns where it is."""

    name = "seek"

    def choose(self, belief, forecast: list | None = None) -> tuple[np.ndarray, np.ndarray, int]:
        cands, scores, best = self.scored(belief)
        if not np.isfinite(scores[best]):
            return cands, scores, best
        flight = self.flight(belief, forecast)
        rate, steps, goal, total = flight
        if steps <= 1 or rate <= total - scores[best]:
            return cands, scores, self.untie(belief, forecast, cands, scores, best, flight)
        return cands, scores, nearest(cands, np.isfinite(scores), goal)


class Weighted(GridOptimizer):
    """The ``weighted`` policy: Eq. (13) with each target's trace weighted by its largest
    over the moves (:func:`decide` with ``weighted``), so the targets the UAV knows least
    about count most; ours."""

    name = "weighted"
    weighted = True
