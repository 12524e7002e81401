"""OFFBOARD setpoints from another system: SET_POSITION_TARGET_LOCAL_NED, its type_mask honoured as PX4's
mavlink_receiver honours it (an ignored group is absent, not zero).

- position, velocity and acceleration all given (the bench's stream): tracked as sent;
- position and velocity: tracked as sent, no acceleration feed-forward;
- position only (MAVSDK's `offboard.set_position_ned`): a smooth move to it at the navigator's limits; PX4 jumps
  its position controller's setpoint instead and lets MPC_XY_VEL_MAX bound the flight there;
- velocity only (`set_velocity_ned`): the reference moves at it, reaching a new velocity at MPC_ACC_HOR /
  MPC_ACC_UP_MAX / MPC_ACC_DOWN_MAX.
Yaw ignored: the heading stays. Frames other than MAV_FRAME_LOCAL_NED, yaw rate and acceleration-only setpoints
are not flown (the message is dropped). OFFBOARD needs a setpoint younger than COM_OF_LOSS_T.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pymavlink.dialects.v20.common import MAV_FRAME_LOCAL_NED

from firmware_interface.emulator.control import Setpoint
from firmware_interface.emulator.navigator import Navigator
from firmware_interface.emulator.step_read import AFX, COORDINATE_FRAME, SETPOINT_FIELD_NAMES, TYPE_MASK, VX, YAW, X
from firmware_interface.emulator.trajectory import Move, velocity_step

IGNORE_POSITION, IGNORE_VELOCITY, IGNORE_ACCELERATION, IGNORE_YAW = 0b111, 0b111 << 3, 0b111 << 6, 1 << 10


class OffboardInput:
    """The last setpoint another system sent, and when (simulated µs)."""

    def __init__(self) -> None:
        self.setpoint: Setpoint | None = None
        self.kind = ""  # "full", "position_velocity", "position", "velocity"
        self.yaw: float | None = None
        self.received_us: int | None = None
        self.target: tuple[float, float, float] | None = None  # a position-only setpoint's position
        self.changes = 0  # counts position-only targets that differ from the one before

    def receive(self, msg: Any, now_us: int) -> None:
        """A SET_POSITION_TARGET_LOCAL_NED message (its fields in `step_read`'s order, then as `take`)."""
        self.take(np.array([getattr(msg, name) for name in SETPOINT_FIELD_NAMES], dtype=float), now_us)

    def take(self, fields: np.ndarray, now_us: int) -> None:
        """A SET_POSITION_TARGET_LOCAL_NED's fields (`step_read`'s layout), received at `now_us`."""
        if fields[COORDINATE_FRAME] != MAV_FRAME_LOCAL_NED:
            return
        mask = int(fields[TYPE_MASK])
        has_pos, has_vel, has_acc = (not mask & IGNORE_POSITION, not mask & IGNORE_VELOCITY,
                                     not mask & IGNORE_ACCELERATION)
        kind = ("full" if has_pos and has_vel and has_acc else "position_velocity" if has_pos and has_vel
                else "position" if has_pos else "velocity" if has_vel else "")
        if not kind:
            return
        pos_ned = fields[X:X + 3].copy()
        setpoint = Setpoint(pos_ned, fields[VX:VX + 3].copy(), fields[AFX:AFX + 3].copy() if has_acc else np.zeros(3),
                            float(fields[YAW]))
        north, east, down = pos_ned.tolist()
        if kind == "position" and (self.kind != kind or self.target != (north, east, down)):
            self.target = (north, east, down)
            self.changes += 1
        self.setpoint, self.kind, self.received_us = setpoint, kind, now_us
        self.yaw = None if mask & IGNORE_YAW else setpoint.yaw

    def fresh(self, now_us: int, timeout_s: float) -> bool:
        return self.received_us is not None and (now_us - self.received_us) * 1e-6 <= timeout_s


class OffboardReference:
    """The navigator's reference in OFFBOARD, from the other system's latest setpoint."""

    def __init__(self, offboard: OffboardInput, navigator: Navigator) -> None:
        self.offboard, self.navigator = offboard, navigator
        self.seen = -1  # the setpoint change the reference was planned for
        self.move: Move | None = None
        self.moving: Setpoint | None = None  # the velocity-driven reference

    def sample(self, t_us: int, dt: float) -> Setpoint:
        offboard = self.offboard
        setpoint = offboard.setpoint
        assert setpoint is not None
        if offboard.kind == "full":
            return setpoint
        if offboard.kind == "position_velocity":
            return Setpoint(setpoint.pos_ned, setpoint.vel_ned, setpoint.acc_ned, self._yaw())
        if offboard.kind == "position":
            if self.move is None or self.seen != offboard.changes:
                self.seen, self.moving = offboard.changes, None
                self.move = Move(self._start(), t_us, setpoint.pos_ned, offboard.yaw, self.navigator.limits())
            return self.move.sample(t_us, dt)
        return self._at_velocity(setpoint.vel_ned, dt)

    @property
    def descending(self) -> bool:
        """A velocity setpoint downwards (MAVSDK tests land in offboard so): the land detector watches."""
        setpoint = self.offboard.setpoint
        return self.offboard.kind == "velocity" and setpoint is not None and setpoint.vel_ned[2] > 0

    def _start(self) -> Setpoint:
        last = self.navigator.last
        assert last is not None
        return last

    def _yaw(self) -> float:
        yaw = self.offboard.yaw
        return yaw if yaw is not None else self._start().yaw

    def _at_velocity(self, wanted_ned: np.ndarray, dt: float) -> Setpoint:
        """Velocity towards the wanted one at the acceleration limits, position its integral."""
        self.move = None
        moved = velocity_step(self.moving or self._start(), wanted_ned, self.navigator.limits(), dt)
        self.moving = Setpoint(moved.pos_ned, moved.vel_ned, moved.acc_ned, self._yaw())
        return self.moving
