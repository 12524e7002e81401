"""`reference: {type: helix}`: the paper's §4 reference, a circle climbing at a constant rate, fixed yaw."""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Literal

import numpy as np
from pydantic import ConfigDict, Field

from hil.scenario.fields import MAX_SPEED_M_S, Length, MissionTime
from hil.scenario.reference.base import FieldProblem, ReferenceModel, RefSample, time_warp, wrap_yaw
from hil.sensors.geodesy import MAX_DISTANCE_M

MAX_ANGULAR_RATE = 10.0  # rad/s, a turn in 0.63 s: beyond any multirotor; keeps r·ω² finite (≤ 1000 m/s²)


class HelixRef(ReferenceModel):
    """Centred above home, starting `radius_m` north of it at `altitude_m`, entered through a `ramp_s` smooth
    start (0: the paper's start, with a velocity step of radius_m·angular_rate and climb_rate at t = 0)."""

    model_config = ConfigDict(json_schema_extra={"examples": [
        {"type": "helix", "radius_m": 1.0, "angular_rate": 0.5, "climb_rate": 1.0, "yaw_deg": 30.0,
         "altitude_m": 10.0},
        {"type": "helix", "radius_m": 3.0, "angular_rate": -0.8, "climb_rate": -0.2, "yaw_deg": 180.0,
         "altitude_m": 25.0, "ramp_s": 4.0}]})

    type: Literal["helix"]
    radius_m: Length = 1.0
    angular_rate: float = Field(0.5, ge=-MAX_ANGULAR_RATE, le=MAX_ANGULAR_RATE, description="rad/s, > 0 clockwise "
                                                                                             "seen from above")
    climb_rate: float = Field(1.0, ge=-MAX_SPEED_M_S, le=MAX_SPEED_M_S, description="m/s, > 0 up")
    yaw_deg: float = 30.0
    altitude_m: Length = 10.0
    ramp_s: MissionTime = 2.0

    def trajectory(self) -> Helix:
        return Helix((0.0, 0.0, -self.altitude_m), self.radius_m, self.angular_rate, self.climb_rate,
                     wrap_yaw(math.radians(self.yaw_deg)), self.ramp_s)

    def problems(self, duration_s: float) -> Iterator[FieldProblem]:
        """Its speed within the bench's speeds; its altitude at the end of the mission (the circle's
        extremes are within the radius' own bound) within the bench's distances."""
        speed = math.hypot(self.radius_m * self.angular_rate, self.climb_rate)
        if speed > MAX_SPEED_M_S:
            yield FieldProblem("angular_rate", self.angular_rate,
                               f"speed along the helix {speed:g} m/s (radius_m·angular_rate and climb_rate) is over "
                               f"{MAX_SPEED_M_S:g} m/s; expected a smaller radius_m, angular_rate or climb_rate")
        end_altitude = self.altitude_m + self.climb_rate * time_warp(duration_s, self.ramp_s)[0]
        if abs(end_altitude) > MAX_DISTANCE_M:
            yield FieldProblem("climb_rate", self.climb_rate,
                               f"ends the mission at {end_altitude:g} m above home, beyond {MAX_DISTANCE_M:g} m; "
                               "expected a smaller climb_rate or a shorter duration_s")


@dataclass(frozen=True)
class Helix:
    """x = r cos(ωτ), y = r sin(ωτ), climbing at `climb_rate`, fixed yaw, on the warped time τ(t).

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
        """In scalars, each product in the order the vector form (dpos·τ̇, ddpos·τ̇·τ̇ + dpos·τ̈) takes: sampled
        every step of a 1 kHz flight before its sensor frame, five 3-vector operations cost ~4 µs."""
        tau, rate, rate_dot = time_warp(t, self.ramp_s)
        w, r, climb = self.angular_rate, self.radius, self.climb_rate
        c, s = math.cos(w * tau), math.sin(w * tau)
        n0, e0, d0 = self.center_ned
        dn, de, dd = -r * w * s, r * w * c, -climb  # d/dτ
        ddn, dde = -r * w * w * c, -r * w * w * s
        return RefSample(np.array((n0 + r * c, e0 + r * s, d0 - climb * tau)),
                         np.array((dn * rate, de * rate, dd * rate)),
                         np.array((ddn * rate * rate + dn * rate_dot, dde * rate * rate + de * rate_dot,
                                   0.0 * rate * rate + dd * rate_dot)), self.yaw)
