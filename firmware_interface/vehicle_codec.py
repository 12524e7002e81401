"""The messages the bench sends a board as other parts of the system would: BATTERY_STATUS as the vehicle's battery
(a smart battery, component MAV_COMP_ID_BATTERY) reports it, MANUAL_CONTROL as QGroundControl's joystick sends it.
SI values in, MAVLink's units out (common.xml), as PX4 v1.15.4 reads them (mavlink_receiver.cpp
handle_message_battery_status, handle_message_manual_control)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from pymavlink.dialects.v20.common import (
    MAV_BATTERY_CHARGE_STATE_UNDEFINED,
    MAV_BATTERY_FUNCTION_ALL,
    MAV_BATTERY_TYPE_LIPO,
    MAV_COMP_ID_BATTERY,
)

from firmware_interface.link import Link
from firmware_interface.link.encoder import FrameEncoder, message_class

BATTERY_COMPONENT_ID = MAV_COMP_ID_BATTERY  # PX4 takes BATTERY_STATUS from any component of its system but its own
UINT16_MAX, INT16_MAX, INT32_MAX = 0xFFFF, 0x7FFF, 0x7FFFFFFF
CELLS, EXTENDED_CELLS = 10, 4  # voltages[10] and voltages_ext[4]: cells 1..10 and 11..14
MAX_CELL_MV = UINT16_MAX - 1
STICK_SCALE = 1000  # MANUAL_CONTROL's x, y, r in [-1000, 1000]; z in [0, 1000]


def _clamp(value: int, low: int, high: int) -> int:
    return max(low, min(high, value))


def cell_millivolts(voltage_v: float, cell_voltages_v: Sequence[float]) -> tuple[list[int], list[int]]:
    """voltages[10] and voltages_ext[4] in mV. Cells beyond the pack: UINT16_MAX in voltages (PX4 counts the cells up
    to the first of them), 0 in voltages_ext ("not supported"). Without cell voltages the pack's voltage goes in
    cell 1, the part above 65534 mV in cell 2, as common.xml says."""
    if len(cell_voltages_v):
        millivolts = [_clamp(round(v * 1000), 0, MAX_CELL_MV) for v in cell_voltages_v]
    else:
        total = max(round(voltage_v * 1000), 0)
        millivolts = [min(total, MAX_CELL_MV)]
        if total > MAX_CELL_MV:
            millivolts.append(min(total - MAX_CELL_MV, MAX_CELL_MV))
    first = millivolts[:CELLS] + [UINT16_MAX] * (CELLS - min(len(millivolts), CELLS))
    extended = millivolts[CELLS:CELLS + EXTENDED_CELLS]
    return first, extended + [0] * (EXTENDED_CELLS - len(extended))


def remaining_percent(remaining: float) -> int:
    """BATTERY_STATUS.battery_remaining: the state of charge in whole percent, rounded (PX4 reads it / 100)."""
    return _clamp(round(remaining * 100), 0, 100)


def battery_status_fields(voltage_v: float, current_a: float, consumed_c: float, remaining: float,
                          cell_voltages_v: Sequence[float]) -> dict[str, Any]:
    """BATTERY_STATUS: cell voltages in mV, current in cA (discharging; -1 would say unknown), charge drawn in mAh
    (C / 3.6),
    remaining in whole percent (rounded), no temperature, energy or time estimate."""
    voltages, voltages_ext = cell_millivolts(voltage_v, cell_voltages_v)
    return {"id": 0, "battery_function": MAV_BATTERY_FUNCTION_ALL, "type": MAV_BATTERY_TYPE_LIPO,
            "temperature": INT16_MAX, "voltages": voltages,
            "current_battery": _clamp(round(current_a * 100), 0, INT16_MAX),
            "current_consumed": _clamp(round(consumed_c / 3.6), 0, INT32_MAX), "energy_consumed": -1,
            "battery_remaining": remaining_percent(remaining), "time_remaining": 0,
            "charge_state": MAV_BATTERY_CHARGE_STATE_UNDEFINED, "voltages_ext": voltages_ext, "mode": 0,
            "fault_bitmask": 0}


def manual_control_fields(target_system: int, pitch: float, roll: float, throttle: float,
                          yaw: float) -> dict[str, Any]:
    """MANUAL_CONTROL from sticks in [-1, 1] (PX4's manual_control_setpoint): x pitch and y roll in [-1000, 1000],
    z throttle in [0, 1000] with 500 centred (PX4 reads throttle = z / 500 - 1), r yaw; no buttons, no extensions."""
    def axis(value: float) -> int:
        return _clamp(round(value * STICK_SCALE), -STICK_SCALE, STICK_SCALE)

    throttle_z = _clamp(round((throttle + 1.0) * STICK_SCALE / 2), 0, STICK_SCALE)
    return {"target": target_system, "x": axis(pitch), "y": axis(roll), "z": throttle_z, "r": axis(yaw),
            "buttons": 0, "buttons2": 0, "enabled_extensions": 0, "s": 0, "t": 0, "aux1": 0, "aux2": 0, "aux3": 0,
            "aux4": 0, "aux5": 0, "aux6": 0}


class ComponentSender:
    """Frames from another component of the board's own system, sent on the bench's link to it (a battery: PX4
    takes BATTERY_STATUS only from its own system and not from the autopilot), numbered in its own sequence."""

    def __init__(self, component_id: int) -> None:
        self.encoder = FrameEncoder(1, component_id)

    def send(self, link: Link, message: str, fields: dict[str, Any]) -> None:
        self.encoder.system_id = link.encoder.system_id  # the board's, which the link adopted from its heartbeat
        link.send_frame(self.encoder.encode(message_class(message), fields))
