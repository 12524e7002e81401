"""Stick input from a ground station (MANUAL_CONTROL, as QGroundControl's virtual joystick sends it) and POSCTL
flown from it, as PX4 v1.15.4 reads and flies it (mavlink_receiver.cpp handle_message_manual_control,
flight_mode_manager Sticks.cpp and FlightTaskManualAltitude/Position).

MANUAL_CONTROL: x pitch and y roll in [-1000, 1000], z throttle in [0, 1000] (500 centred), r yaw in [-1000, 1000];
each stick through PX4's deadzone MPC_HOLD_DZ and expo (MPC_XY_MAN_EXPO, MPC_Z_MAN_EXPO, MPC_YAW_EXPO). POSCTL:
pitch/roll ask for a horizontal velocity up to MPC_VEL_MANUAL in the heading frame, throttle a vertical one up to
MPC_Z_VEL_MAX_UP above centre and MPC_Z_VEL_MAX_DN below, yaw a yaw rate up to MPC_MAN_Y_MAX; the reference
reaches a new velocity at MPC_ACC_HOR_MAX / MPC_ACC_UP_MAX / MPC_ACC_DOWN_MAX, and with the sticks centred it
comes to rest and holds the position. Input older than COM_RC_LOSS_T counts as lost (sticks centred).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from firmware_interface.emulator.control import Setpoint
from firmware_interface.emulator.geometry import wrap_pi
from firmware_interface.emulator.px4_params import Px4Values
from firmware_interface.emulator.trajectory import Limits, velocity_step


def expo_deadzone(value: float, expo: float, deadzone: float) -> float:
    """PX4's math::expo_deadzone: a deadzone rescaled to keep ±1, then (1 − e)·x + e·x³."""
    x = min(max(value, -1.0), 1.0)
    dz = min(max(deadzone, 0.0), 0.99)
    x = (x - math.copysign(dz, x)) / (1 - dz) if abs(x) > dz else 0.0
    e = min(max(expo, 0.0), 1.0)
    return (1 - e) * x + e * x**3


class ManualInput:
    """The last stick positions a ground station sent, and when (simulated µs)."""

    def __init__(self) -> None:
        self.pitch = self.roll = self.yaw = self.throttle = 0.0  # PX4's manual_control_setpoint, each in [-1, 1]
        self.received_us: int | None = None

    def receive(self, msg: Any, now_us: int) -> None:
        self.pitch, self.roll = msg.x / 1000.0, msg.y / 1000.0
        self.throttle = msg.z / 1000.0 * 2.0 - 1.0  # PX4 reads z in [0, 1000]
        self.yaw = msg.r / 1000.0
        self.received_us = now_us

    def fresh(self, now_us: int, timeout_s: float) -> bool:
        return self.received_us is not None and (now_us - self.received_us) * 1e-6 <= timeout_s

    def sticks(self, params: Px4Values) -> tuple[float, float, float, float]:
        """Forward, right, down and yaw after PX4's deadzone and expo (Sticks::getPositionExpo)."""
        dz, xy, z, yaw = (params["MPC_HOLD_DZ"], params["MPC_XY_MAN_EXPO"], params["MPC_Z_MAN_EXPO"],
                          params["MPC_YAW_EXPO"])
        return (expo_deadzone(self.pitch, xy, dz), expo_deadzone(self.roll, xy, dz),
                expo_deadzone(-self.throttle, z, dz), expo_deadzone(self.yaw, yaw, dz))


class StickReference:
    """POSCTL from the sticks: the reference moves at the velocity they ask for."""

    descending = False

    def __init__(self, manual: ManualInput, params: Px4Values, start: Setpoint, fresh: Any) -> None:
        self.manual, self.params = manual, params
        self.setpoint = Setpoint(start.pos_ned.copy(), start.vel_ned.copy(), np.zeros(3), start.yaw)
        self.fresh = fresh  # () -> bool: stick input within COM_RC_LOSS_T

    def sample(self, t_us: int, dt: float) -> Setpoint:
        p = self.params
        forward, right, down, yaw = self.manual.sticks(p) if self.fresh() else (0.0, 0.0, 0.0, 0.0)
        heading = self.setpoint.yaw
        cos_h, sin_h = math.cos(heading), math.sin(heading)
        speed_xy = p["MPC_VEL_MANUAL"]
        wanted = np.array(((cos_h * forward - sin_h * right) * speed_xy, (sin_h * forward + cos_h * right) * speed_xy,
                           down * (p["MPC_Z_VEL_MAX_DN"] if down > 0 else p["MPC_Z_VEL_MAX_UP"])))
        limits = Limits(speed_xy, p["MPC_Z_VEL_MAX_UP"], p["MPC_Z_VEL_MAX_DN"], p["MPC_ACC_HOR_MAX"],
                        p["MPC_ACC_UP_MAX"], p["MPC_ACC_DOWN_MAX"], math.radians(p["MPC_MAN_Y_MAX"]))
        moved = velocity_step(self.setpoint, wanted, limits, dt)
        self.setpoint = Setpoint(moved.pos_ned, moved.vel_ned, moved.acc_ned,
                                 wrap_pi(heading + yaw * limits.yaw_rate * dt))
        return self.setpoint
