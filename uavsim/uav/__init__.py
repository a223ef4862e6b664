"""UAV policies ([Papaioannou2023] Sec. V-B, VI-B): where the sensors are and how
they move, one registry of interchangeable objects.

A :class:`Policy` is reset at the start of a trial (drawing its start from its own
stream), names the observers ``(S, 3)`` that scan this step and the sensor they carry,
and moves with :meth:`Policy.act` once the belief has been predicted.  :data:`POLICIES`
maps the names a mission or the command line uses to their makers:

* ``optimized``: the grid move of least summed pseudo-posterior trace (Eq. 3, 12-13),
  or a move chosen from outside (``Simulation.step(action)``, the Gymnasium environment);
* ``weighted``: Eq. (13) with each target's trace weighted by its size over the moves
  (ours; the targets known least about count most, :class:`.grid.Weighted`);
* ``seek``: Eq. (13)'s move, or a flight to the target whose bearing would tell most per
  step of the way when that pays more (ours, :class:`.grid.Seek`);
* ``lookahead``: the grid move of least covariance trace accumulated over a rollout of
  the myopic rule for several steps (non-myopic; :mod:`.lookahead`);
* ``zigzag``, ``square``, ``pentagon``, ``circle``: pre-computed loops (Fig. 3);
* ``fixed-sensors``: three static sensors without false alarms (Fig. 2c);
* ``baseline``: no sensor (the no-information baseline).

**Policy and planner.**  In the code a UAV behaviour is a *policy* (:class:`Policy`,
:data:`POLICIES`, :func:`make_policy`, ``Simulation.policy``; to *plan* is the guidance's
word, for the targets' paths, :mod:`uavsim.guidance`).  Users pick a policy by its name,
and there the word is *planner*, kept so that existing missions and scripts work: the
mission's ``[planner]`` section (``Mission.planner``, :class:`PlannerConfig`, as every
section has its config class), ``uavsim run --planner`` and ``compare --planners``,
:data:`PLANNERS` (the names), the ``planner`` entries of a campaign's manifest and summary
(the name, and the seconds per step the policy took).  A function that takes such a name
calls its argument ``planner`` (``Simulation``, ``run_campaign``, ``run_trial``).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from typing import Protocol

import numpy as np

from ..declare import setting
from ..mission import Mission
from ..sensing import BearingModel
from .fixed import FixedSensors, FixedSensorsConfig, NoSensor
from .grid import GridOptimizer, Seek, UavConfig, Weighted, admissible, candidates, decide, move_offsets, uav_start
from .lookahead import Lookahead, LookaheadConfig
from .manoeuvres import MANOEUVRES, Manoeuvre, ManoeuvreConfig, Route, manoeuvre_loop, manoeuvre_route, place_loop

POLICIES = {"optimized": GridOptimizer, "weighted": Weighted, "seek": Seek, "lookahead": Lookahead,
            **{n: partial(Manoeuvre, n) for n in MANOEUVRES}, "fixed-sensors": FixedSensors, "baseline": NoSensor}
PLANNERS = tuple(POLICIES)  # the names users give: `--planner`, [planner] name
BASELINE = "baseline"  # the policy every study is measured against

__all__ = ["POLICIES", "PLANNERS", "BASELINE", "MANOEUVRES", "Policy", "PlannerConfig", "UavConfig", "ManoeuvreConfig",
           "FixedSensorsConfig", "LookaheadConfig", "GridOptimizer", "Weighted", "Seek", "Lookahead", "Manoeuvre",
           "FixedSensors", "NoSensor", "Route", "make_policy", "decide",
           "admissible", "candidates", "move_offsets", "uav_start", "manoeuvre_loop", "manoeuvre_route", "place_loop"]


@dataclass(frozen=True, eq=False)
class PlannerConfig:
    """Which UAV policy runs (Sec. V-B, VI-B) and the settings of the alternatives."""

    name: str = setting("name", "optimized", choices=PLANNERS,
                        doc="the UAV policy a run uses (`uavsim run --planner` picks another)")
    manoeuvres: ManoeuvreConfig = ManoeuvreConfig()
    fixed_sensors: FixedSensorsConfig = FixedSensorsConfig()
    lookahead: LookaheadConfig = LookaheadConfig()


class Policy(Protocol):
    """A UAV behaviour.  ``sensor`` is None for the no-sensor baseline; ``uav`` the UAV's
    position ``(3,)`` or None when no UAV flies."""

    name: str
    sensor: BearingModel | None

    def reset(self, rng: np.random.Generator) -> None:
        """Place the observers for a new trial."""

    @property
    def observers(self) -> np.ndarray:
        """``(S, 3)`` where the sensors are this step."""

    @property
    def uav(self) -> np.ndarray | None: ...

    def act(self, t: int, belief, action: int | None = None, forecast: list | None = None
            ) -> tuple[np.ndarray | None, np.ndarray | None]:
        """Move for step ``t + 1`` given the predicted belief and, per target, the means
        ``(T, 6)`` of the guidance plan it was predicted with (``forecast``; None when the
        filter predicts with other forces); returns the candidate positions and their
        scores where the policy chose among candidates."""


def make_policy(name: str, mission: Mission) -> Policy:
    if name not in POLICIES:
        raise ValueError(f"unknown planner {name!r}; choose from {', '.join(POLICIES)}")
    return POLICIES[name](mission)
