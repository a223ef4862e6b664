"""A validated mission, the one record a run needs, and the error that names a bad key.

:func:`uavsim.config.load_mission` makes a :class:`Mission` from a file; every setting in
it is an object defined beside the code that uses it (``World``, ``Dynamics``,
``Sensor``, ``GuidanceConfig``, ``FilterConfig``, ``UavConfig``, ``PlannerConfig``).
"""

from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .declare import SettingError, setting

if TYPE_CHECKING:  # annotations only: the settings' modules import MissionError from here
    from .belief import FilterConfig
    from .guidance.model import GuidanceConfig
    from .sensing import Sensor
    from .targets import Dynamics, Target
    from .uav import PlannerConfig, UavConfig
    from .world import World

TRUTH_MODES = ("planned", "stochastic")


class MissionError(Exception):
    """A bad mission or world file: which file, which key, what is wrong."""

    def __init__(self, file: str | Path, key: str, message: str):
        super().__init__(f"{file}: {key}: {message}")
        self.file, self.key, self.message = str(file), key, message

    def __reduce__(self):  # raised in a worker process, re-raised here
        return MissionError, (self.file, self.key, self.message)


@contextmanager
def mission_errors(path: str | Path):
    """Domain code raises :class:`uavsim.declare.SettingError` (a key path and what is
    wrong); within this block it becomes a :class:`MissionError` naming the mission file."""
    try:
        yield
    except SettingError as exc:
        raise MissionError(path, exc.key, exc.message) from None


@dataclass(frozen=True, eq=False)
class Mission:
    """A validated mission: everything a run needs, nothing read later.

    ``truth``: how the true targets move (see :mod:`uavsim.truth`), one of
    :data:`TRUTH_MODES`."""

    path: Path
    world_path: Path
    world: World
    dynamics: Dynamics
    targets: tuple[Target, ...]
    sensor: Sensor
    uav: UavConfig
    guidance: GuidanceConfig
    filter: FilterConfig
    planner: PlannerConfig
    steps: int = setting("steps", 50, lo=1, hi=100_000, doc="time steps per trial")
    trials: int = setting("trials", 10, lo=1, hi=1_000_000, doc="Monte-Carlo trials (`uavsim run --trials`)")
    seed: int = setting("seed", 0, lo=0, hi=2**63 - 1, doc="the campaign's seed; trial k is seeded from "
                                                           "SeedSequence(seed).spawn(trials)[k]")
    truth: str = setting("truth", "planned", choices=TRUTH_MODES,
                         doc="planned: the truth follows its noise-free first plan; stochastic: re-planned, noisy")
    description: str = setting("description", "", doc="one line shown by `uavsim validate`")

    @property
    def goals(self) -> np.ndarray:
        """(M, 3) each target's goal centroid ``G_o`` (Eq. 7)."""
        return np.array([self.world.goals[t.goal].centroid for t in self.targets])
