"""The flight plan of a run: take off to the reference's start, fly the reference, land.

Times: the mission clock t is 0 when the reference starts; take-off happens at t < 0.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hil.scenario.reference import RefSample, Trajectory, TrajectorySource, Waypoints
from hil.scenario.schema import Scenario

CLIMB_SPEED = 1.5  # m/s peak on the take-off and landing segments
HOLD_BEFORE_S = 2.0  # hover at the start point before the mission clock starts


def _point(pos_ned: np.ndarray) -> tuple[float, float, float]:
    return float(pos_ned[0]), float(pos_ned[1]), float(pos_ned[2])


@dataclass
class MissionPlan:
    reference: Trajectory
    takeoff: Waypoints
    takeoff_s: float  # take-off and hold before t = 0
    duration_s: float

    @classmethod
    def build(cls, scenario: Scenario, ground_ned: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> MissionPlan:
        source: TrajectorySource = scenario.reference  # every member of the union builds its own trajectory
        reference = source.trajectory()
        start = reference.sample(0.0)
        above_ground = (ground_ned[0], ground_ned[1], float(start.pos_ned[2]))
        takeoff = Waypoints((ground_ned, above_ground, _point(start.pos_ned)), CLIMB_SPEED, 0.0, start.yaw)
        return cls(reference, takeoff, takeoff.duration_s + HOLD_BEFORE_S, scenario.duration_s)

    def sample(self, t: float) -> RefSample:
        """Reference at mission time t (negative during take-off)."""
        if t >= 0:
            return self.reference.sample(t)
        return self.takeoff.sample(t + self.takeoff_s)

    def landing(self, from_ned: np.ndarray, yaw: float) -> Waypoints:
        ground = (float(from_ned[0]), float(from_ned[1]), 0.0)
        return Waypoints((_point(from_ned), ground), CLIMB_SPEED, 0.0, yaw)
