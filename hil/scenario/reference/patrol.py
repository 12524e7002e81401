"""`reference: {type: patrol}`: power-line inspection, back and forth beside the line, facing it."""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from functools import cached_property
from typing import Literal

import numpy as np
from pydantic import ConfigDict, Field

from hil.scenario.fields import Length, MissionTime, Position, Speed
from hil.scenario.reference.base import FieldProblem, ReferenceModel, RefSample, wrap_yaw
from hil.scenario.reference.waypoints import Waypoints
from hil.sensors.geodesy import MAX_DISTANCE_M

MAX_PASSES = 1000
MIN_LINE_M = 1.0  # horizontal: the standoff side and the heading facing the line come from its direction


class PatrolRef(ReferenceModel):
    model_config = ConfigDict(json_schema_extra={"examples": [
        {"type": "patrol", "line_start_ned": [0.0, 0.0, 0.0], "line_end_ned": [28.3, 28.3, 0.0], "standoff_m": 5.0,
         "altitude_m": 12.0, "speed": 3.0, "dwell_s": 2.0, "passes": 2},
        {"type": "patrol", "line_start_ned": [10.0, 0.0, 0.0], "line_end_ned": [10.0, -30.0, 0.0], "passes": 3}]})

    type: Literal["patrol"]
    line_start_ned: Position
    line_end_ned: Position
    standoff_m: Length = 5.0
    altitude_m: Length = 10.0
    speed: Speed = 3.0
    dwell_s: MissionTime = 2.0
    passes: int = Field(2, ge=1, le=MAX_PASSES)

    def trajectory(self) -> Patrol:
        return Patrol(self.line_start_ned, self.line_end_ned, self.standoff_m, self.altitude_m, self.speed,
                      self.dwell_s, self.passes)

    def problems(self, duration_s: float) -> Iterator[FieldProblem]:
        """A line with a direction; the flown ends (the line's, moved by the standoff and the altitude) within the
        bench's distances."""
        start, end = self.line_start_ned, self.line_end_ned
        length = math.hypot(end[0] - start[0], end[1] - start[1])
        if length < MIN_LINE_M:
            yield FieldProblem("line_end_ned", end, f"the line from {list(start)} to {list(end)} is {length:.3g} m "
                               f"long horizontally; expected at least {MIN_LINE_M:g} m (its direction sets the "
                               "standoff side and the heading)")
            return
        ends = self.trajectory().as_waypoints.points_ned[:2]
        for field, end in zip(("line_start_ned", "line_end_ned"), ends, strict=True):
            if max(abs(v) for v in end) > MAX_DISTANCE_M:
                flown = ", ".join(f"{v:g}" for v in end)
                yield FieldProblem(field, getattr(self, field),
                                   f"flown at ({flown}) m NED with the standoff and the altitude, beyond "
                                   f"{MAX_DISTANCE_M:g} m of home; expected a line nearer home")


@dataclass(frozen=True)
class Patrol:
    """Inspection along a power line from `line_start` to `line_end` (NED, on the ground): fly parallel to
    it at `standoff_m` to the right of the line direction and `altitude_m` above ground, facing the line,
    back and forth `passes` times with `dwell_s` at each end."""

    line_start_ned: tuple[float, float, float]
    line_end_ned: tuple[float, float, float]
    standoff_m: float = 5.0
    altitude_m: float = 10.0
    speed: float = 3.0
    dwell_s: float = 2.0
    passes: int = 2

    @cached_property
    def as_waypoints(self) -> Waypoints:
        a, b = np.array(self.line_start_ned, float), np.array(self.line_end_ned, float)
        direction = (b - a) / max(float(np.linalg.norm(b - a)), 1e-9)
        right = np.array((-direction[1], direction[0], 0.0))
        offset = self.standoff_m * right - np.array((0.0, 0.0, self.altitude_m))
        ends = [tuple(a + offset), tuple(b + offset)]
        points = [ends[i % 2] for i in range(self.passes + 1)]
        facing_line = wrap_yaw(math.atan2(-right[1], -right[0]))
        return Waypoints(tuple(points), self.speed, self.dwell_s, facing_line)

    def sample(self, t: float) -> RefSample:
        return self.as_waypoints.sample(t)
