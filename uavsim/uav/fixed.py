"""Policies without a flying UAV: the 3-sensor baseline (004 Sec. VI-B) and no sensor.

* ``fixed-sensors``: static bearing sensors (the paper's at [150, 200], [800, 200],
  [500, 900] m) receive a bearing of every target each step, without false alarms;
* ``baseline``: no sensor at all, so the belief only predicts: the no-information
  baseline every study is measured against.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..mission import Mission
from ..sensing import Sensor


@dataclass(frozen=True, eq=False)
class FixedSensorsConfig:
    """The 3-sensor baseline of Sec. VI-B: static bearing sensors, no false alarms."""

    positions: np.ndarray  # (S, 3)
    sensor: Sensor


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
        self.observers = mission.planner.fixed_sensors.positions
        self.sensor = mission.planner.fixed_sensors.sensor


class NoSensor(_Static):
    name = "baseline"
    sensor = None
    observers = np.zeros((0, 3))

    def __init__(self, mission: Mission):
        pass
