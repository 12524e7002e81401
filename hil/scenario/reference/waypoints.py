"""`reference: {type: waypoints}`: rest-to-rest segments between points at a peak speed, a dwell at each."""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass
from functools import cached_property
from itertools import pairwise
from typing import Literal

import numpy as np
from pydantic import ConfigDict, Field

from hil.scenario.fields import MissionTime, Position, Speed
from hil.scenario.reference.base import ReferenceModel, RefSample, wrap_yaw

MAX_WAYPOINTS = 10_000  # a long inspection route; the reference finds its segment by bisection
PEAK_RATE = 1.875  # max of ds/dx for the quintic smoothstep


class WaypointsRef(ReferenceModel):
    model_config = ConfigDict(json_schema_extra={"examples": [
        {"type": "waypoints", "points_ned": [[0.0, 0.0, -10.0], [20.0, 0.0, -10.0], [20.0, -15.0, -14.0],
                                             [0.0, 0.0, -10.0]], "speed": 4.0, "dwell_s": 1.0},
        {"type": "waypoints", "points_ned": [[5.0, 5.0, -3.0], [-5.0, 5.0, -8.0]], "speed": 1.5, "yaw_deg": 270.0}]})

    type: Literal["waypoints"]
    points_ned: list[Position] = Field(min_length=2, max_length=MAX_WAYPOINTS)
    speed: Speed = 2.0
    dwell_s: MissionTime = 0.0
    yaw_deg: float | None = None  # None: face along each segment

    def trajectory(self) -> Waypoints:
        yaw = wrap_yaw(math.radians(self.yaw_deg)) if self.yaw_deg is not None else None
        return Waypoints(tuple(self.points_ned), self.speed, self.dwell_s, yaw)


def smoothstep(x: float) -> tuple[float, float, float]:
    """Quintic smoothstep s(x) and its derivatives: rest-to-rest with zero acceleration at both ends."""
    x = min(max(x, 0.0), 1.0)
    return (10 * x**3 - 15 * x**4 + 6 * x**5, 30 * x**2 - 60 * x**3 + 30 * x**4, 60 * x - 180 * x**2 + 120 * x**3)


@dataclass(frozen=True)
class Waypoints:
    """Rest-to-rest segments between points at a peak speed, with a dwell at each point."""

    points_ned: tuple[tuple[float, float, float], ...]
    speed: float = 2.0
    dwell_s: float = 0.0
    yaw: float | None = None  # None: face along each segment

    @cached_property
    def _segments(self) -> list[tuple[float, np.ndarray, np.ndarray, float, float]]:
        """(start time, from, to, duration, yaw) per segment, built once."""
        out, t = [], 0.0
        pts = [np.array(p, float) for p in self.points_ned]
        for a, b in pairwise(pts):
            length = float(np.linalg.norm(b - a))
            duration = max(PEAK_RATE * length / self.speed, 1e-6)
            yaw = self.yaw if self.yaw is not None else wrap_yaw(math.atan2(b[1] - a[1], b[0] - a[0]))
            out.append((t, a, b, duration, yaw))
            t += duration + self.dwell_s
        return out

    @cached_property
    def _starts(self) -> list[float]:
        return [segment[0] for segment in self._segments]

    @property
    def duration_s(self) -> float:
        segments = self._segments
        return segments[-1][0] + segments[-1][3] if segments else 0.0

    def sample(self, t: float) -> RefSample:
        """O(log n) in the number of points: the segment by bisection of the start times."""
        index = max(bisect.bisect_right(self._starts, t) - 1, 0)
        start, a, b, duration, yaw = self._segments[index]
        s, ds, dds = smoothstep((t - start) / duration)
        delta = b - a
        return RefSample(a + s * delta, ds / duration * delta, dds / duration**2 * delta, yaw)
