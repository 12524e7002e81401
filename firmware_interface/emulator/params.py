"""The emulator's parameters as a ground station sees them (PARAM_REQUEST_LIST / _READ / PARAM_SET).

The active controller's position-loop gains, which its update reads every step, so a value set in flight
takes effect on the next step; SYS_HITL, MAV_SYS_ID and EKF2_GPS_DELAY; and the PX4 parameters of the
commander and navigator (`px4_params.py`), with PX4's names, units and types (an INT32 one's value C-cast
into param_value, as MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT says). Gains of the attitude loop and the
differentiator are fixed at start-up (they are built into filters), so they are not offered.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from pymavlink.dialects.v20.common import MAV_PARAM_TYPE_INT32, MAV_PARAM_TYPE_REAL32, MAV_SEVERITY_INFO

from firmware_interface.emulator.control.registry import PLUGINS
from firmware_interface.emulator.px4_params import PX4_PARAMS, Px4Values

if TYPE_CHECKING:
    from firmware_interface.emulator.firmware import EmulatedBoard


@dataclass(frozen=True)
class Parameter:
    name: str  # as on the wire, at most 16 characters
    get: Callable[[], float]
    set: Callable[[float], None] | None  # None: read-only
    param_type: int = MAV_PARAM_TYPE_REAL32


def _gain(controller: Any, field: str) -> Parameter:
    def set_gain(value: float) -> None:
        controller.gains = controller.gains.model_copy(update={field: value})

    prefix = PLUGINS[controller.name].param_prefix
    return Parameter(f"{prefix}_{field.upper()}"[:16], lambda: float(getattr(controller.gains, field)), set_gain)


def _px4(values: Px4Values, name: str) -> Parameter:
    kind = MAV_PARAM_TYPE_INT32 if PX4_PARAMS[name].integer else MAV_PARAM_TYPE_REAL32
    return Parameter(name, lambda: values[name], lambda value: values.set(name, value), kind)


def parameter_table(board: EmulatedBoard) -> list[Parameter]:
    """The parameters of an EmulatedBoard, in the order a ground station lists them."""
    controller = board.controller
    table = [_gain(controller, field) for field in PLUGINS[controller.name].runtime_gains]

    def set_gps_delay(ms: float) -> None:
        board.estimator.settings = board.estimator.settings.model_copy(update={"gps_delay_s": ms / 1000.0})

    table += [
        Parameter("SYS_HITL", lambda: 1.0, None, MAV_PARAM_TYPE_INT32),
        Parameter("MAV_SYS_ID", lambda: float(board.config.system_id), None, MAV_PARAM_TYPE_INT32),
        Parameter("EKF2_GPS_DELAY", lambda: board.estimator.settings.gps_delay_s * 1000.0, set_gps_delay),
    ]
    return table + [_px4(board.params, name) for name in PX4_PARAMS]


class ParameterServer:
    """The MAVLink parameter protocol over the table: every PARAM_VALUE carries its index and the count."""

    def __init__(self, board: EmulatedBoard) -> None:
        self.board = board
        self.table = parameter_table(board)
        self.index = {p.name: i for i, p in enumerate(self.table)}

    def handle(self, msg: Any) -> None:
        kind = msg.get_type()
        if kind == "PARAM_REQUEST_LIST":
            for index in range(len(self.table)):
                self.send(index)
            return
        name = msg.param_id.rstrip("\0") if isinstance(msg.param_id, str) else ""
        index = self.index.get(name, -1)
        if kind == "PARAM_REQUEST_READ" and index < 0 and 0 <= msg.param_index < len(self.table):
            index = msg.param_index
        if index < 0:
            return  # unknown: PX4 does not answer either
        parameter = self.table[index]
        if kind == "PARAM_SET" and parameter.set is not None:
            parameter.set(float(msg.param_value))
            self.board.status(MAV_SEVERITY_INFO, f"{parameter.name} set to {parameter.get():g}")
        self.send(index)  # for a read-only one, the unchanged value says it was not set

    def send(self, index: int) -> None:
        parameter = self.table[index]
        self.board.link.send("PARAM_VALUE", param_id=parameter.name, param_value=parameter.get(),
                             param_type=parameter.param_type, param_count=len(self.table), param_index=index)
