"""Reference trajectories (NED, SI): hover, the paper's helix, waypoints, power-line patrol.

Each gives position, velocity, acceleration and yaw at time t. A trajectory that starts
moving is entered through a smooth time warp τ(t) whose rate ramps from 0 to 1 over
`ramp_s` (C² continuous), so the vehicle is never asked for a velocity step at t = 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
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
