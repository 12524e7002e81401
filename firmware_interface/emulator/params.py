"""The emulator's parameters as a ground station sees them (PARAM_REQUEST_LIST / _READ / PARAM_SET).

The active controller's position-loop gains, which its update reads every step, so a value set in flight
takes effect on the next step; and a few PX4-named parameters with the same meaning and units as in
PX4, two of them settable. Gains of the attitude loop and the differentiator are fixed at start-up (they
are built into filters), so they are not offered.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from firmware_interface.emulator.control.registry import PLUGINS


@dataclass(frozen=True)
class Parameter:
    name: str  # as on the wire, at most 16 characters
    get: Callable[[], float]
    set: Callable[[float], None] | None  # None: read-only


def _gain(controller: Any, field: str) -> Parameter:
    def set_gain(value: float) -> None:
        controller.gains = controller.gains.model_copy(update={field: value})

    prefix = PLUGINS[controller.name].param_prefix
    return Parameter(f"{prefix}_{field.upper()}"[:16], lambda: float(getattr(controller.gains, field)), set_gain)


def parameter_table(board: Any) -> list[Parameter]:
    """The parameters of an EmulatedBoard, in the order a ground station lists them."""
    controller = board.controller
    table = [_gain(controller, field) for field in PLUGINS[controller.name].runtime_gains]

    def set_gps_delay(ms: float) -> None:
        board.estimator.settings = board.estimator.settings.model_copy(update={"gps_delay_s": ms / 1000.0})

    def set_land_speed(value: float) -> None:
        board.land_speed_m_s = value

    table += [
        Parameter("SYS_HITL", lambda: 1.0, None),
        Parameter("MAV_SYS_ID", lambda: float(board.config.system_id), None),
        Parameter("EKF2_GPS_DELAY", lambda: board.estimator.settings.gps_delay_s * 1000.0, set_gps_delay),
        Parameter("MPC_LAND_SPEED", lambda: board.land_speed_m_s, set_land_speed),
    ]
    return table
