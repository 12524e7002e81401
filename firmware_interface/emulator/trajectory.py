"""The navigator's references: smooth, feasible motions the paper's controllers track.

A move flies a straight line to a target at rest, as PX4's trajectory heads for its target along the line from the
previous waypoint: a quintic polynomial carries the reference along the line, its duration keeping the peak speed
and acceleration within PX4's limits for that direction (for a rest-to-rest quintic the peak speed is 1.875·d/T
and the peak acceleration 5.774·d/T²); a second, short quintic takes off what else the reference started with
(its offset from the line, its velocity across or back along it, its acceleration) within the acceleration limits.
The two sum to the start's position, velocity and acceleration, so the reference stays C² whatever was flown
before. Yaw turns along a quintic smoothstep at no more than MPC_YAWRAUTO_MAX. A hold returns one fixed setpoint;
a descent moves down at a constant rate and lets the ground stop it, as PX4's land mode does.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from firmware_interface.emulator.compiled import flight_code
from firmware_interface.emulator.control import Setpoint
from firmware_interface.emulator.geometry import wrap_pi

PEAK_SPEED = 1.875  # max of ds/dx of the quintic smoothstep s(x) = 10x³ − 15x⁴ + 6x⁵
PEAK_ACCEL = 10 / math.sqrt(3)  # max of |d²s/dx²|
MIN_MOVE_S = 0.5  # the shortest move: a hold point a few centimetres off still comes smoothly
# The acceleration of a quintic from (x, v, a) at τ = t/T = 0 to rest at 0 at τ = 1 is
# x/T²·ACC_X(τ) + v/T·ACC_V(τ) + a·ACC_A(τ) (from quintic_coefficients with p1 = 0), sampled here on a grid of τ.
_TAU = np.linspace(0.0, 1.0, 129)
ACC_X = -60 * _TAU + 180 * _TAU**2 - 120 * _TAU**3
ACC_V = -36 * _TAU + 96 * _TAU**2 - 60 * _TAU**3
ACC_A = 1 - 9 * _TAU + 18 * _TAU**2 - 10 * _TAU**3
BLEND_TOLERANCE = 0.01  # the blend's duration is found to within this fraction
LONGEST_BLEND_S = 600.0


@dataclass(frozen=True)
class Limits:
    """Peak speeds (m/s), accelerations (m/s²) and yaw rate (rad/s) of a move, from PX4's MPC_* parameters."""

    speed_xy: float
    speed_up: float
    speed_down: float
    accel_xy: float
    accel_up: float
    accel_down: float
    yaw_rate: float


class Reference(Protocol):
    """What the flight code tracks at each control step; `descending`: towards the ground (the land detector runs)."""

    @property
    def descending(self) -> bool: ...

    def sample(self, t_us: int, dt: float) -> Setpoint: ...


class Hold:
    """A fixed setpoint: the same object every step."""

    descending = False

    def __init__(self, setpoint: Setpoint) -> None:
        self.setpoint = setpoint

    def sample(self, t_us: int, dt: float) -> Setpoint:
        return self.setpoint


class Descent:
    """Down at `speed()` m/s from `start` (held horizontally) until the ground stops the vehicle; the setpoint's
    height moves by speed·dt each step, the rate read each step (MPC_LAND_SPEED may be set during a landing)."""

    descending = True

    def __init__(self, start: Setpoint, speed: Callable[[], float]) -> None:
        self.setpoint = start
        self.speed = speed

    def sample(self, t_us: int, dt: float) -> Setpoint:
        self.setpoint.pos_ned[2] += self.speed() * dt
        return self.setpoint


@flight_code
def quintic_sample(coeffs: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Position, velocity and acceleration at time t of p(t) = Σ c_k t^k, one row of six coefficients per axis."""
    pos, vel, acc = np.empty(3), np.empty(3), np.empty(3)
    for i in range(3):
        c0, c1, c2, c3, c4, c5 = coeffs[i]
        pos[i] = c0 + t * (c1 + t * (c2 + t * (c3 + t * (c4 + t * c5))))
        vel[i] = c1 + t * (2 * c2 + t * (3 * c3 + t * (4 * c4 + t * 5 * c5)))
        acc[i] = 2 * c2 + t * (6 * c3 + t * (12 * c4 + t * 20 * c5))
    return pos, vel, acc


def quintic_coefficients(p0: np.ndarray, v0: np.ndarray, a0: np.ndarray, p1: np.ndarray, duration_s: float
                         ) -> np.ndarray:
    """Coefficients of the quintic from (p0, v0, a0) at t = 0 to p1 at rest (zero velocity and acceleration) at
    t = T, per axis: the unique solution of the six boundary conditions."""
    t = duration_s
    d = p1 - p0
    c3 = (20 * d - 12 * v0 * t - 3 * a0 * t**2) / (2 * t**3)
    c4 = (-30 * d + 16 * v0 * t + 3 * a0 * t**2) / (2 * t**4)
    c5 = (12 * d - 6 * v0 * t - a0 * t**2) / (2 * t**5)
    return np.ascontiguousarray(np.column_stack((p0, v0, a0 / 2, c3, c4, c5)))


def move_duration(start: Setpoint, target_ned: np.ndarray, limits: Limits) -> float:
    """Long enough that a rest-to-rest move over the distance keeps every peak within `limits`, and that the
    speed it starts with can be taken off at the horizontal acceleration limit."""
    d = target_ned - start.pos_ned
    horizontal, vertical = math.hypot(d[0], d[1]), float(d[2])
    speed_z, accel_z = (limits.speed_down, limits.accel_down) if vertical > 0 else (limits.speed_up, limits.accel_up)
    speed_now = float(np.linalg.norm(start.vel_ned))
    return max(MIN_MOVE_S, PEAK_SPEED * horizontal / limits.speed_xy,
               math.sqrt(PEAK_ACCEL * horizontal / limits.accel_xy), PEAK_SPEED * abs(vertical) / speed_z,
               math.sqrt(PEAK_ACCEL * abs(vertical) / accel_z), 2 * speed_now / limits.accel_xy)


def blend_duration(offset: np.ndarray, vel: np.ndarray, acc: np.ndarray, limits: Limits) -> float:
    """The duration (within BLEND_TOLERANCE of the shortest) of the quintic that takes (offset, vel, acc) to rest at
    zero with its acceleration within MPC_ACC_HOR horizontally and the lesser of the up/down limits vertically
    (or within the start's own acceleration, where that is more), and the offset coming back no faster than the
    speed limits (1.875·x/T)."""
    limit_xy = max(limits.accel_xy, math.hypot(acc[0], acc[1]))
    limit_z = max(min(limits.accel_up, limits.accel_down), abs(float(acc[2])))

    def within(duration_s: float) -> bool:
        a = np.outer(ACC_X, offset) / duration_s**2 + np.outer(ACC_V, vel) / duration_s + np.outer(ACC_A, acc)
        return bool(np.hypot(a[:, 0], a[:, 1]).max() <= limit_xy and np.abs(a[:, 2]).max() <= limit_z)

    short = max(MIN_MOVE_S, PEAK_SPEED * math.hypot(offset[0], offset[1]) / limits.speed_xy,
                PEAK_SPEED * abs(float(offset[2])) / min(limits.speed_up, limits.speed_down))
    if within(short):
        return short
    long = 2 * short
    while not within(long):  # the a-term alone is within its limit: a long enough blend always is
        if long > LONGEST_BLEND_S:  # not a finite start (a NaN from outside): no duration will do
            return long
        short, long = long, 2 * long
    while long - short > BLEND_TOLERANCE * short:
        middle = (short + long) / 2
        short, long = (short, middle) if within(middle) else (middle, long)
    return long


class Move:
    """From the reference `start` (at `start_us`) to rest at `target_ned`, turning to `yaw` (None: keep), along the
    line from `line_start` (a mission leg's previous waypoint; None: where the reference starts) to the target.

    Along the line: a quintic from the start's foot on the line, at the start's speed along it (forward only), to
    rest at the target. The rest of the start (offset from the line, velocity across or back along it,
    acceleration): a quintic to rest at zero over `blend_s`, as short as the acceleration limits allow. One quintic
    per axis from the whole start over the whole leg instead would carry that rest for the leg's duration T: a
    velocity v across the line takes the reference 0.1975·v·T off it (5 m for 1 m/s on a 40 m leg at 3 m/s)."""

    descending = False

    def __init__(self, start: Setpoint, start_us: int, target_ned: np.ndarray, yaw: float | None,
                 limits: Limits, line_start: np.ndarray | None = None) -> None:
        self.start_us = start_us
        self.target_ned = np.asarray(target_ned, dtype=float)
        origin = start.pos_ned if line_start is None else np.asarray(line_start, dtype=float)
        line = self.target_ned - origin
        length = float(np.linalg.norm(line))
        unit = line / length if length > 1e-9 else np.zeros(3)
        foot = origin + unit * float((start.pos_ned - origin) @ unit)
        along = unit * max(float(start.vel_ned @ unit), 0.0)
        self.duration_s = move_duration(Setpoint(foot, along, np.zeros(3), start.yaw), self.target_ned, limits)
        self.coeffs = quintic_coefficients(foot, along, np.zeros(3), self.target_ned, self.duration_s)
        offset, across = start.pos_ned - foot, start.vel_ned - along
        self.blend: np.ndarray | None = None
        self.blend_s = 0.0
        if offset.any() or across.any() or start.acc_ned.any():
            self.blend_s = blend_duration(offset, across, start.acc_ned, limits)
            self.blend = quintic_coefficients(offset, across, start.acc_ned, np.zeros(3), self.blend_s)
        self.yaw0 = start.yaw
        self.yaw_turn = 0.0 if yaw is None else wrap_pi(yaw - start.yaw)
        self.yaw_s = PEAK_SPEED * abs(self.yaw_turn) / limits.yaw_rate
        self.end_us = start_us + round(1e6 * max(self.duration_s, self.blend_s))

    def sample(self, t_us: int, dt: float) -> Setpoint:
        t = max((t_us - self.start_us) * 1e-6, 0.0)
        pos, vel, acc = quintic_sample(self.coeffs, min(t, self.duration_s))
        if self.blend is not None and t < self.blend_s:
            blend_pos, blend_vel, blend_acc = quintic_sample(self.blend, t)
            pos, vel, acc = pos + blend_pos, vel + blend_vel, acc + blend_acc
        return Setpoint(pos, vel, acc, self.yaw_at(t))

    def yaw_at(self, t: float) -> float:
        if self.yaw_turn == 0.0:
            return self.yaw0
        x = min(t / self.yaw_s, 1.0)
        return wrap_pi(self.yaw0 + self.yaw_turn * x**3 * (10 - 15 * x + 6 * x**2))

    def finished(self, t_us: int) -> bool:
        return t_us >= self.end_us and (t_us - self.start_us) * 1e-6 >= self.yaw_s


def velocity_step(start: Setpoint, wanted_ned: np.ndarray, limits: Limits, dt: float) -> Setpoint:
    """One step of a reference driven by a wanted velocity: its velocity moves towards the wanted one at the
    acceleration limits (horizontal, up, down), its position is the integral."""
    change = wanted_ned - start.vel_ned
    step = np.array(change)
    horizontal = math.hypot(float(change[0]), float(change[1]))
    if horizontal > limits.accel_xy * dt:
        step[:2] *= limits.accel_xy * dt / horizontal
    z_limit = (limits.accel_down if change[2] > 0 else limits.accel_up) * dt
    step[2] = max(min(float(step[2]), z_limit), -z_limit)
    vel = start.vel_ned + step
    return Setpoint(start.pos_ned + vel * dt, vel, step / dt if dt > 0 else np.zeros(3), start.yaw)
