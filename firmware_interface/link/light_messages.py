"""The messages of every lockstep step, and the board's streams the bench reads, decoded without pymavlink's
message machinery.

pymavlink decodes a frame in ~15 µs (its header again, the checksum again, a message object built through its
generic constructor); a step's HIL_SENSOR, setpoint and truth on the board's side and the actuator reply on the
bench's took ~20 % of the emulator's CPU. The board's attitude, position, attitude target and controller state
streams (~80 frames a second of flight time each) cost the bench ~10 µs a lockstep step, on the step's critical
path: the bench reads the reply while the board waits for the next frame. The scanner has checked the frame
already, so here the payload is only unpacked with the message's own struct (zeros restored where MAVLink 2
trimmed them) into an object with the message's field names and the few methods the bench and the emulator call
(`get_type`, `get_srcSystem`, `get_srcComponent`, `get_msgbuf`). The values are pymavlink's own (its struct, its
field order, its reading of a text field; tests compare them with pymavlink's decode).
"""

from __future__ import annotations

import struct
from operator import itemgetter
from typing import Any, ClassVar, Self

from pymavlink.dialects.v20 import common

HEADER = 10  # bytes before a MAVLink 2 payload


class LightMessage(tuple):
    """A decoded frame: the payload's values in wire order, then the frame; each field by its name."""

    __slots__ = ()
    _type: ClassVar[str]
    _unpacker: ClassVar[struct.Struct]

    def __new__(cls, frame: bytes) -> Self:
        payload = frame[HEADER:HEADER + frame[1]]  # a signature, if any, comes after the checksum
        size = cls._unpacker.size
        values = cls._unpacker.unpack(payload + bytes(size - len(payload)) if len(payload) < size else payload[:size])
        return tuple.__new__(cls, (*values, frame))

    def get_type(self) -> str:
        return self._type

    def get_srcSystem(self) -> int:
        return self[-1][5]

    def get_srcComponent(self) -> int:
        return self[-1][6]

    def get_msgbuf(self) -> bytes:
        return self[-1]


def _array(start: int, end: int) -> property:
    return property(lambda message: list(message[start:end]))


def _text(at: int) -> property:
    """A char[] field (one bytes value in the struct) as pymavlink reads it: up to its first NUL, as ASCII."""
    return property(lambda message: message[at].split(b"\x00", 1)[0].decode("ascii", errors="replace"))


def _light(message: Any) -> type[LightMessage]:
    """A light class of a pymavlink message class: numbers, number arrays and text fields."""
    fields: dict[str, Any] = {"__slots__": (), "_type": message.msgname, "_unpacker": message.unpacker}
    kinds = dict(zip(message.fieldnames, message.fieldtypes, strict=True))
    at = 0
    for name, length in zip(message.ordered_fieldnames, message.array_lengths, strict=True):
        if kinds[name] == "char":
            fields[name] = _text(at)
            at += 1
        elif length > 1:
            fields[name] = _array(at, at + length)
            at += length
        else:
            fields[name] = property(itemgetter(at))
            at += 1
    return type(f"Light{message.msgname.title().replace('_', '')}", (LightMessage,), fields)


LIGHT: dict[int, type[LightMessage]] = {message.id: _light(message) for message in (
    common.MAVLink_hil_sensor_message, common.MAVLink_hil_gps_message,
    common.MAVLink_set_position_target_local_ned_message, common.MAVLink_odometry_message,
    common.MAVLink_hil_state_quaternion_message, common.MAVLink_hil_actuator_controls_message,
    common.MAVLink_attitude_message, common.MAVLink_local_position_ned_message, common.MAVLink_attitude_target_message,
    common.MAVLink_debug_float_array_message, common.MAVLink_extended_sys_state_message)}
