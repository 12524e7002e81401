"""The board's own messages as the bench records and publishes them: MAVLink fields to SI payloads named
with their frame (the channels of `hil/channels.py` type them)."""

from __future__ import annotations

from typing import Any

from firmware_interface import hil_codec as codec
from firmware_interface.emulator.control.registry import INTERNAL_KEYS_BY_WIRE_NAME
from firmware_interface.emulator.geometry import quat_to_euler
from firmware_interface.link import Message


def decode_board_message(msg: Message) -> tuple[str, dict[str, Any]] | None:
    """(kind, payload in SI with frame-named fields) of a message the bench records; None for the others."""
    kind = msg.get_type()
    if kind == "ATTITUDE_TARGET":
        return kind, {"q": list(msg.q), "rpy": quat_to_euler(msg.q).tolist(), "thrust": msg.thrust}
    if kind == "DEBUG_FLOAT_ARRAY":
        keys = INTERNAL_KEYS_BY_WIRE_NAME.get(msg.name, ())
        values = dict(zip(keys, msg.data, strict=False)) if keys else {f"v{i}": v for i, v in enumerate(msg.data) if v}
        return kind, {"name": msg.name, "values": values}
    if kind == "HEARTBEAT":
        return kind, {"armed": bool(msg.base_mode & codec.MODE_FLAG_ARMED), "custom_mode": msg.custom_mode,
                      "system_status": msg.system_status}
    if kind == "STATUSTEXT":
        return kind, {"severity": msg.severity, "text": msg.text}
    if kind == "COMMAND_ACK":
        return kind, {"command": msg.command, "result": msg.result}
    if kind == "LOCAL_POSITION_NED":
        return kind, {"pos_ned": [msg.x, msg.y, msg.z], "vel_ned": [msg.vx, msg.vy, msg.vz]}
    if kind == "ATTITUDE":
        return kind, {"rpy": [msg.roll, msg.pitch, msg.yaw]}
    if kind == "EXTENDED_SYS_STATE":
        return kind, {"landed_state": msg.landed_state}
    if kind == "MISSION_CURRENT":
        return kind, {"seq": msg.seq, "total": msg.total}
    if kind == "MISSION_ITEM_REACHED":
        return kind, {"seq": msg.seq}
    return None
