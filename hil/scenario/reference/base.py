"""What every reference type shares: the sample a trajectory gives at time t, the contract of a `reference:`
model (build its trajectory, name what it cannot fly), the smooth start and the yaw's range."""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from typing import NamedTuple, Protocol

import numpy as np

from hil.scenario.fields import ScenarioModel


@dataclass(frozen=True)
class RefSample:
    """The reference at one time: NED position (m), velocity (m/s), acceleration (m/s²), yaw (rad, (−π, π])."""

    pos_ned: np.ndarray
    vel_ned: np.ndarray
    acc_ned: np.ndarray
    yaw: float


class Trajectory(Protocol):
    def sample(self, t: float) -> RefSample: ...


class FieldProblem(NamedTuple):
    """Something a reference cannot fly, at one of its fields: the field, its value, why and what is expected."""

    field: str
    value: object
    reason: str


class TrajectorySource(Protocol):
    """What every member of the `reference:` union is; mypy checks it where the plan takes the scenario's."""

    @property
    def type(self) -> str:
        """The tag that picks the member: `reference: {type: ...}`."""
        ...

    def trajectory(self) -> Trajectory:
        """The trajectory the fields describe, in SI units and NED, sampled on the mission clock."""
        ...

    def problems(self, duration_s: float) -> Iterator[FieldProblem]:
        """What the fields' own bounds cannot say: limits of the flown path over a mission of `duration_s`."""
        ...


class ReferenceModel(ScenarioModel):
    """Base of the `reference:` models: most types' field bounds say all there is to check."""

    def problems(self, duration_s: float) -> Iterator[FieldProblem]:
        return iter(())


def wrap_yaw(yaw: float) -> float:
    """The angle in (−π, π]; an angle already there comes back bit for bit (IEEE remainder is exact)."""
    wrapped = math.remainder(yaw, math.tau)
    return math.pi if wrapped == -math.pi else wrapped


def time_warp(t: float, ramp_s: float) -> tuple[float, float, float]:
    """τ, τ̇, τ̈ with τ̇ = smoothstep5(t / ramp_s): τ̇ goes 0 → 1, then τ = t − ramp_s/2.

    A trajectory that starts moving runs on τ rather than t, so the vehicle is never asked for a velocity
    step at t = 0: τ̇ and τ̈ start at 0 and τ is C³."""
    if ramp_s <= 0 or t >= ramp_s:
        return t - max(ramp_s, 0.0) / 2, 1.0, 0.0
    s = max(t, 0.0) / ramp_s
    rate = 10 * s**3 - 15 * s**4 + 6 * s**5
    tau = ramp_s * (2.5 * s**4 - 3 * s**5 + s**6)
    rate_dot = (30 * s**2 - 60 * s**3 + 30 * s**4) / ramp_s
    return tau, rate, rate_dot
