"""A validated mission, the one record a run needs, and the error that names a bad key.

:func:`uavsim.config.load_mission` makes a :class:`Mission` from a file; every setting in
it is an object defined beside the code that uses it (``World``, ``Dynamics``,
``BearingModel``, ``GuidanceConfig``, ``FilterConfig``, ``UavConfig``, ``PlannerConfig``).
"""

from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .declare import SettingError, setting

__all__ = ["Mission", "MissionError", "advisories", "mission_errors"]  # the public interface (docs/api.md)

if TYPE_CHECKING:  # annotations only: the settings' modules import MissionError from here
    from .belief import FilterConfig
    from .guidance.model import GuidanceConfig
    from .sensing import BearingModel
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
    sensor: BearingModel
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


# Particles that must fall within 2 sigma of a bearing in a step (:func:`advisories`):
# measured on the paper mission (5000 particles, 4 trials x 20 steps, RMSE / no
# information): sigma_deg 1: 0.48, 0.1: 0.50, 0.03 (about 390 such particles): 0.51, 0.01
# (130): 0.68, 0.003 (40): 0.86, 0.001 (13): 0.92.
RESOLVED_PARTICLES = 300


def advisories(m: Mission) -> list[str]:
    """What a valid mission's settings make likely to go wrong, said before a run (the
    command line prints each as a warning): a process noise that leaves resampled
    particles identical (some horizontal direction without noise, no roughening), and
    bearings finer than the particle filter resolves.  In a step the process noise spreads
    a target's particles over about ``s = sqrt(max eig Q_xy)`` metres across the line of
    sight; at range ``r`` a bearing
    of noise sigma keeps those within ``2 sigma r``: about ``N 4 sigma r / (sqrt(2 pi) s)``
    of N particles, for the nearest target at the UAV's start.  Fewer than
    :data:`RESOLVED_PARTICLES` and the weights collapse onto a few particles."""
    if m.filter.kind != "particle" or m.sensor is None:
        return []
    horizontal = np.ix_([0, 1, 3, 4], [0, 1, 3, 4])
    if np.linalg.eigvalsh(m.dynamics.q[horizontal]).min() <= 0.0 and m.filter.roughening == 0.0:
        return ["dynamics.process_noise_cov_si has no noise along some horizontal direction and filter.roughening is "
                "0: resampled particles stay copies of each other there (impoverishment; NEES grows step by step); "
                "set filter.roughening > 0 (e.g. 0.2)"]
    s = float(np.sqrt(max(np.linalg.eigvalsh(m.dynamics.q[:2, :2]).max(), 0.0)))
    if s == 0.0:  # no process noise in position: nothing spreads the particles in a step
        return []
    ranges = [float(np.linalg.norm(t.mean0[:2] - m.uav.start[:2])) for t in m.targets]
    k = int(np.argmin(ranges))
    n = m.filter.particles * 4.0 * m.sensor.sigma * max(ranges[k], 1.0) / (np.sqrt(2.0 * np.pi) * s)
    if n >= RESOLVED_PARTICLES:
        return []
    more = RESOLVED_PARTICLES / n
    return [f"sensor.sigma_deg {np.degrees(m.sensor.sigma):g} is finer than filter.particles {m.filter.particles} "
            f"resolve: about {n:.0f} particles fall within 2 sigma of {m.targets[k].name}'s bearing "
            f"({ranges[k]:.0f} m away) after a step's process noise ({s:.1f} m); below {RESOLVED_PARTICLES} the "
            f"filter degenerates (RMSE towards no information): use about {np.ceil(m.filter.particles * more):.0f} "
            f"particles, or sigma_deg >= {np.degrees(m.sensor.sigma) * more:.2g}"]
