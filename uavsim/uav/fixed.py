"""Policies without a flying UAV: the 3-sensor baseline ([Papaioannou2023, Sec. VI-B]) and no sensor.

* ``fixed-sensors``: static bearing sensors (the paper's at [150, 200], [800, 200],
  [500, 900] m) receive a bearing of every target each step, without false alarms;
* ``baseline``: no sensor at all, so the belief only predicts: the no-information
  baseline every study is measured against.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..declare import SettingError, setting
from ..mission import Mission
from ..sensing import BearingModel
from ..world import World, fmt, inside_polytopes


@dataclass(frozen=True, eq=False)
class FixedSensorsConfig:
    """The 3-sensor baseline of Sec. VI-B: static bearing sensors, no false alarms."""

    positions: np.ndarray = setting("positions_m", kind="array", unit="m", shape=(None, 2),
                                    derived="(0.15, 0.2), (0.8, 0.2), (0.5, 0.9) of the area (the paper's on 1 km)",
                                    doc="ground positions [x, y] of the static sensors (z = 0); (S, 3) once read")
    p_detect: float = setting("p_detect", 1.0, lo=0, hi=1, doc="their detection probability")
    clutter_rate: float = setting("clutter_rate", 0.0, unit="per scan", lo=0, hi=100, doc="their false alarm rate")


# Sec. VI-B's sensors at [150, 200], [800, 200], [500, 900] m of a 1 km area, as fractions.
FIXED_FRACTIONS = np.array([[0.15, 0.2], [0.8, 0.2], [0.5, 0.9]])


def fixed_sensor(mission: Mission) -> BearingModel:
    """The fixed sensors' :class:`BearingModel`: the UAV's noise, their own p_D and clutter."""
    f = mission.planner.fixed_sensors
    return replace(mission.sensor, p_detect=f.p_detect, clutter_rate=f.clutter_rate)


def fixed_sensor_problem(positions: np.ndarray, world: World) -> str | None:
    """None if every fixed sensor ``(S, 3)`` (on the ground) lies in the area and outside
    obstacles, else which one and why.  The derived defaults are checked only when the
    fixed-sensors policy runs (:class:`uavsim.uav.FixedSensors`)."""
    xy = positions[:, :2]
    inside_area = np.all((xy >= world.area_lo[:2]) & (xy <= world.area_hi[:2]), axis=1)
    in_obstacle = world.in_obstacle(positions)
    bad = np.flatnonzero(~inside_area | in_obstacle)
    if not len(bad):
        return None
    k = int(bad[0])
    if not inside_area[k]:
        area = f"{fmt(world.area_lo[:2])}..{fmt(world.area_hi[:2])}"
        return f"fixed sensor {k} at {fmt(xy[k])} is outside the area {area}"
    hit = inside_polytopes(positions[k], world.normals, world.offsets)
    return f"fixed sensor {k} at {fmt(xy[k])} is inside obstacle '{world.obstacle_names[int(np.argmax(hit))]}'"


class _Static:
    """No UAV; observers that never move."""

    uav = None

    def reset(self, rng: np.random.Generator) -> None:
        return None

    def act(self, t: int, belief, action: int | None = None, forecast: list | None = None):
        if action is not None:
            raise ValueError(f"the {self.name} policy takes no actions")
        return None, None


class FixedSensors(_Static):
    name = "fixed-sensors"

    def __init__(self, mission: Mission):
        problem = fixed_sensor_problem(mission.planner.fixed_sensors.positions, mission.world)
        if problem:
            raise SettingError("planner.fixed_sensors.positions_m",
                               f"{problem}; the mission gives no positions and these defaults (0.15, 0.2), (0.8, 0.2), "
                               "(0.5, 0.9) of the area do not fit: set planner.fixed_sensors.positions_m")
        self.observers = mission.planner.fixed_sensors.positions
        self.sensor = fixed_sensor(mission)


class NoSensor(_Static):
    name = "baseline"
    sensor = None
    observers = np.zeros((0, 3))

    def __init__(self, mission: Mission):
        pass
