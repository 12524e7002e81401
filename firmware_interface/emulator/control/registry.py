"""The controllers the emulator can fly: register a new one here, in `PLUGINS` (CONTRIBUTING.md)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal

import numpy as np

from firmware_interface.emulator.control import backstepping, smarc, smpid
from firmware_interface.emulator.control.base import Controller, Nominal
from firmware_interface.emulator.control.plugin import ControllerPlugin

if TYPE_CHECKING:
    from firmware_interface.emulator.config import EmulatorConfig

PLUGINS: dict[str, ControllerPlugin] = {p.name: p for p in (smarc.PLUGIN, smpid.PLUGIN, backstepping.PLUGIN)}
CONTROLLERS = tuple(PLUGINS)
if TYPE_CHECKING:  # the names are data (the registry); to a type checker a controller name is a string
    ControllerName = str
else:
    ControllerName = Literal[CONTROLLERS]
# The order of each controller's values in its DEBUG_FLOAT_ARRAY (named after the controller).
INTERNAL_KEYS: dict[str, tuple[str, ...]] = {name: p.controller.internal_keys for name, p in PLUGINS.items()}
DEBUG_NAME_LENGTH = 10  # DEBUG_FLOAT_ARRAY.name is char[10]: "backstepping" arrives as "backsteppi"


def wire_name(controller: str) -> str:
    """The controller's name as DEBUG_FLOAT_ARRAY carries it."""
    return controller[:DEBUG_NAME_LENGTH]


INTERNAL_KEYS_BY_WIRE_NAME = {wire_name(name): keys for name, keys in INTERNAL_KEYS.items()}


def make_controller(config: EmulatorConfig) -> Controller:
    """The configured controller, on the configured nominal vehicle, with its gains."""
    v = config.vehicle
    nominal = Nominal(v.mass, np.array((v.Ixx, v.Iyy, v.Izz)), v.g)
    return PLUGINS[config.controller].build(nominal, getattr(config.gains, config.controller))
