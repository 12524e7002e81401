"""The paper's three controllers behind one interface: state + setpoint + dt -> thrust and body torques."""

from __future__ import annotations

import numpy as np

from firmware_interface.emulator.config import EmulatorConfig
from firmware_interface.emulator.control.backstepping import Backstepping
from firmware_interface.emulator.control.base import ControlOutput, Controller, Nominal, Setpoint, VehicleState
from firmware_interface.emulator.control.smarc import Smarc
from firmware_interface.emulator.control.smpid import SlidingModePid

CONTROLLERS = ("smarc", "smpid", "backstepping")
# The order of each controller's values in its DEBUG_FLOAT_ARRAY (named after the controller).
INTERNAL_KEYS: dict[str, tuple[str, ...]] = {c.name: c.internal_keys for c in (Smarc, SlidingModePid, Backstepping)}


def make_controller(config: EmulatorConfig) -> Controller:
    v = config.vehicle
    nominal = Nominal(v.mass, np.array((v.Ixx, v.Iyy, v.Izz)), v.g)
    if config.controller == "smarc":
        return Smarc(nominal, config.gains.smarc)
    if config.controller == "smpid":
        return SlidingModePid(nominal, config.gains.smpid)
    return Backstepping(nominal, config.gains.backstepping)


__all__ = ["CONTROLLERS", "INTERNAL_KEYS", "ControlOutput", "Controller", "Nominal", "Setpoint", "VehicleState", "make_controller"]
