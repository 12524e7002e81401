"""Mission items as the MAVLink mission protocol carries them, read and written as PX4 v1.15.4 does
(mavlink_mission.cpp: parse_mavlink_mission_item, format_mavlink_mission_item), for the items this emulator flies.

An item PX4 would store but this emulator does not fly (LOITER_UNLIM, DO_JUMP, camera and gimbal commands, ...)
is refused with MAV_MISSION_UNSUPPORTED, the result PX4 gives a command it does not know; a frame PX4 does not
take (local frames) with MAV_MISSION_UNSUPPORTED_FRAME. Positions are degrees and metres, yaw in radians.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from pymavlink.dialects.v20.common import (
    MAV_CMD_DO_CHANGE_SPEED,
    MAV_CMD_NAV_LAND,
    MAV_CMD_NAV_LOITER_TIME,
    MAV_CMD_NAV_RETURN_TO_LAUNCH,
    MAV_CMD_NAV_TAKEOFF,
    MAV_CMD_NAV_WAYPOINT,
    MAV_FRAME_GLOBAL,
    MAV_FRAME_GLOBAL_INT,
    MAV_FRAME_GLOBAL_RELATIVE_ALT,
    MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
    MAV_FRAME_MISSION,
    MAV_MISSION_UNSUPPORTED,
    MAV_MISSION_UNSUPPORTED_FRAME,
)

POSITION_COMMANDS = (MAV_CMD_NAV_WAYPOINT, MAV_CMD_NAV_LOITER_TIME, MAV_CMD_NAV_LAND, MAV_CMD_NAV_TAKEOFF)
ACTION_COMMANDS = (MAV_CMD_DO_CHANGE_SPEED, MAV_CMD_NAV_RETURN_TO_LAUNCH)  # frame MAV_FRAME_MISSION, no position
_ABSOLUTE = (MAV_FRAME_GLOBAL, MAV_FRAME_GLOBAL_INT)
_RELATIVE = (MAV_FRAME_GLOBAL_RELATIVE_ALT, MAV_FRAME_GLOBAL_RELATIVE_ALT_INT)


@dataclass(frozen=True)
class MissionItem:
    """One stored item: a position item (lat/lon in degrees, altitude in m, relative to home or AMSL) or an
    action (DO_CHANGE_SPEED, RETURN_TO_LAUNCH) with its params and x, y, z kept as sent."""

    command: int
    params: tuple[float, float, float, float]
    lat_deg: float = 0.0
    lon_deg: float = 0.0
    altitude_m: float = 0.0
    relative_alt: bool = True
    autocontinue: bool = True
    raw_xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)  # an action's x, y, z as sent

    @property
    def has_position(self) -> bool:
        return self.command in POSITION_COMMANDS

    @property
    def yaw_rad(self) -> float | None:
        """The heading the item asks for (param4, deg); None: PX4's default, face along the leg."""
        yaw = self.params[3]
        return None if not math.isfinite(yaw) or self.command == MAV_CMD_NAV_LOITER_TIME else math.radians(yaw)

    @property
    def hold_s(self) -> float:
        """Time inside the acceptance radius before the item counts as reached (param1 of WAYPOINT and
        LOITER_TIME)."""
        if self.command in (MAV_CMD_NAV_WAYPOINT, MAV_CMD_NAV_LOITER_TIME) and math.isfinite(self.params[0]):
            return max(self.params[0], 0.0)
        return 0.0

    @property
    def acceptance_radius_m(self) -> float | None:
        """WAYPOINT's param2 when set (> 0); None: NAV_ACC_RAD."""
        radius = self.params[1]
        return radius if self.command == MAV_CMD_NAV_WAYPOINT and math.isfinite(radius) and radius > 1e-3 else None


def parse_item(msg: Any, int_encoded: bool) -> MissionItem | int:
    """A MISSION_ITEM(_INT) as a stored item, or the MAV_MISSION_RESULT refusing it."""
    frame, command = msg.frame, msg.command
    p = (float(msg.param1), float(msg.param2), float(msg.param3), float(msg.param4))
    global_frames = (MAV_FRAME_GLOBAL, MAV_FRAME_GLOBAL_RELATIVE_ALT) + (
        (MAV_FRAME_GLOBAL_INT, MAV_FRAME_GLOBAL_RELATIVE_ALT_INT) if int_encoded else ())
    if frame in global_frames:
        if command not in POSITION_COMMANDS:
            return MAV_MISSION_UNSUPPORTED
        scale = 1e-7 if int_encoded else 1.0
        return MissionItem(command, _stored_params(command, p), msg.x * scale, msg.y * scale, float(msg.z),
                           frame in _RELATIVE, bool(msg.autocontinue))
    if frame == MAV_FRAME_MISSION:
        if command not in ACTION_COMMANDS:
            return MAV_MISSION_UNSUPPORTED
        return MissionItem(command, p, autocontinue=bool(msg.autocontinue),
                           raw_xyz=(float(msg.x), float(msg.y), float(msg.z)))
    return MAV_MISSION_UNSUPPORTED_FRAME


def _stored_params(command: int, p: tuple[float, float, float, float]) -> tuple[float, float, float, float]:
    """What PX4 keeps of a position item's params (and so returns on download): yaw wrapped to [0, 360) deg,
    LOITER_TIME's heading and exit flags as 0/1, nothing of what it does not read."""
    yaw = math.degrees(math.radians(p[3]) % (2 * math.pi)) if math.isfinite(p[3]) else p[3]
    if command == MAV_CMD_NAV_WAYPOINT:
        return (p[0], p[1], 0.0, yaw)
    if command == MAV_CMD_NAV_LOITER_TIME:
        return (p[0], float(p[1] > 0), p[2], float(p[3] > 0))
    if command == MAV_CMD_NAV_LAND:
        return (0.0, p[1], 0.0, yaw)
    return (0.0, 0.0, 0.0, yaw)  # TAKEOFF


def item_fields(item: MissionItem, seq: int, current: bool, int_encoded: bool) -> dict[str, Any]:
    """MISSION_ITEM(_INT) fields for a download (without the target and mission type), frames and x, y as PX4
    writes them in the mode the ground station asked in."""
    if item.has_position:
        frame = (_RELATIVE if item.relative_alt else _ABSOLUTE)[1 if int_encoded else 0]
        x: float = round(item.lat_deg * 1e7) if int_encoded else item.lat_deg
        y: float = round(item.lon_deg * 1e7) if int_encoded else item.lon_deg
        z = item.altitude_m
    else:
        frame = MAV_FRAME_MISSION
        x, y, z = item.raw_xyz
        if int_encoded:
            x, y = round(x), round(y)
    return {"param1": item.params[0], "param2": item.params[1], "param3": item.params[2], "param4": item.params[3],
            "x": x, "y": y, "z": z, "seq": seq, "command": item.command, "frame": frame, "current": int(current),
            "autocontinue": int(item.autocontinue)}
