"""Reference trajectories (NED, SI): hover, the paper's helix, waypoints, power-line patrol.

Each gives position, velocity, acceleration and yaw at time t. A trajectory that starts
moving is entered through a smooth time warp τ(t) whose rate ramps from 0 to 1 over
`ramp_s` (C² continuous), so the vehicle is never asked for a velocity step at t = 0.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass
from functools import cached_property
from itertools import pairwise
from typing import Protocol

import numpy as np


@dataclass(frozen=True)
class RefSample:
    pos_ned: np.ndarray
    vel_ned: np.ndarray
    acc_ned: np.ndarray
    yaw: float


class Trajectory(Protocol):
    def sample(self, t: float) -> RefSample: ...


def time_warp(t: float, ramp_s: float) -> tuple[float, float, float]:
    """τ, τ̇, τ̈ with τ̇ = smoothstep5(t / ramp_s): τ̇ goes 0 → 1, then τ = t − ramp_s/2."""
    if ramp_s <= 0 or t >= ramp_s:
        return t - max(ramp_s, 0.0) / 2, 1.0, 0.0
    s = max(t, 0.0) / ramp_s
    rate = 10 * s**3 - 15 * s**4 + 6 * s**5
    tau = ramp_s * (2.5 * s**4 - 3 * s**5 + s**6)
    rate_dot = (30 * s**2 - 60 * s**3 + 30 * s**4) / ramp_s
    return tau, rate, rate_dot


@dataclass(frozen=True)
class Hover:
    point_ned: tuple[float, float, float]
    yaw: float = 0.0

    def sample(self, t: float) -> RefSample:
        return RefSample(np.array(self.point_ned, float), np.zeros(3), np.zeros(3), self.yaw)


@dataclass(frozen=True)
class Helix:
    """The paper's §4 reference: x = r cos(ωt), y = r sin(ωt), climbing at `climb_rate`, fixed yaw.

    With the defaults (r = 1 m, ω = 0.5 rad/s, 1 m/s, ψ = π/6) this is x = cos(t/2), y = sin(t/2),
    z = t of the paper, z up (NED: pos_d decreases). `center_ned` is the circle's centre at τ = 0.
    """

    center_ned: tuple[float, float, float] = (0.0, 0.0, -10.0)
    radius: float = 1.0
    angular_rate: float = 0.5
    climb_rate: float = 1.0
    yaw: float = math.pi / 6
    ramp_s: float = 2.0

    def sample(self, t: float) -> RefSample:
        tau, rate, rate_dot = time_warp(t, self.ramp_s)
        w, r = self.angular_rate, self.radius
        c, s = math.cos(w * tau), math.sin(w * tau)
        n0, e0, d0 = self.center_ned
        pos = np.array((n0 + r * c, e0 + r * s, d0 - self.climb_rate * tau))
        dpos = np.array((-r * w * s, r * w * c, -self.climb_rate))  # d/dτ
        ddpos = np.array((-r * w * w * c, -r * w * w * s, 0.0))
        return RefSample(pos, dpos * rate, ddpos * rate * rate + dpos * rate_dot, self.yaw)


def _smooth(x: float) -> tuple[float, float, float]:
    """Quintic smoothstep s(x) and its derivatives: rest-to-rest with zero acceleration at both ends."""
    x = min(max(x, 0.0), 1.0)
    return (10 * x**3 - 15 * x**4 + 6 * x**5, 30 * x**2 - 60 * x**3 + 30 * x**4, 60 * x - 180 * x**2 + 120 * x**3)


PEAK_RATE = 1.875  # max of ds/dx for the quintic smoothstep


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
            yaw = self.yaw if self.yaw is not None else math.atan2(b[1] - a[1], b[0] - a[0])
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
        s, ds, dds = _smooth((t - start) / duration)
        delta = b - a
        return RefSample(a + s * delta, ds / duration * delta, dds / duration**2 * delta, yaw)


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
        facing_line = math.atan2(-right[1], -right[0])
        return Waypoints(tuple(points), self.speed, self.dwell_s, facing_line)

    def sample(self, t: float) -> RefSample:
        return self.as_waypoints.sample(t)
