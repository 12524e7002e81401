"""What the bench asks of a board: a COMMAND_LONG or a parameter. The bench never waits for the answer: it asks
each step until the answer is in the session's report (`board_waits` has the waiting forms scripts use)."""

from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import Any

from pymavlink.dialects.v20.common import (
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_CMD_DO_SET_MODE,
    MAV_CMD_MISSION_START,
    MAV_CMD_NAV_LAND,
)

from firmware_interface import hil_codec as codec
from firmware_interface.link import LinkError
from firmware_interface.px4_modes import FORCE_DISARM_MAGIC, PX4_MAIN_MODE_OFFBOARD


class BoardError(LinkError):
    """The board did not answer as expected (no heartbeat, command refused, silent)."""


def int32_as_float(value: int) -> float:
    """An INT32 parameter in PARAM_SET's float field, byte for byte (the MAVLink parameter protocol's bytewise
    encoding, which PX4 uses: it copies the field's four bytes into the parameter)."""
    return float(struct.unpack("<f", struct.pack("<i", value))[0])


def float_as_int32(wire: float) -> int:
    """PARAM_VALUE's float field read back as the INT32 whose bytes it carries."""
    return int(struct.unpack("<i", struct.pack("<f", wire))[0])


@dataclass(frozen=True)
class Request:
    """A COMMAND_LONG and its parameters (`BoardSession.ask`); its COMMAND_ACK lands in the session's report."""

    command: int
    params: tuple[float, ...] = ()


@dataclass(frozen=True)
class ProtocolMessage:
    """A message of one of MAVLink's protocols other than commands (the mission protocol: MISSION_COUNT,
    MISSION_ITEM_INT, ...), sent to the board's autopilot by `BoardSession.ask`, which fills in the target."""

    type: str  # the MAVLink message name
    fields: tuple[tuple[str, Any], ...]  # (field, value) pairs, target_system and target_component left out


@dataclass(frozen=True)
class ParamSet:
    """A PARAM_SET: a float parameter (REAL32) or an int one (INT32); the board answers with PARAM_VALUE
    (`BoardReport.params`)."""

    name: str
    value: float | int


ARM = Request(MAV_CMD_COMPONENT_ARM_DISARM, (1.0,))
DISARM = Request(MAV_CMD_COMPONENT_ARM_DISARM, (0.0,))
FORCE_DISARM = Request(MAV_CMD_COMPONENT_ARM_DISARM, (0.0, float(FORCE_DISARM_MAGIC)))  # also in the air
OFFBOARD = Request(MAV_CMD_DO_SET_MODE, (float(codec.MODE_FLAG_CUSTOM), float(PX4_MAIN_MODE_OFFBOARD)))
LAND = Request(MAV_CMD_NAV_LAND)  # PX4's AUTO_LAND where the vehicle is


def mission_start(item_count: int) -> Request:
    """MAV_CMD_MISSION_START from the first item to the last (PX4 also arms with it, when it can)."""
    return Request(MAV_CMD_MISSION_START, (0.0, float(item_count - 1)))
