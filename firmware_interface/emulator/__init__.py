"""The board emulator: a software flight controller speaking PX4's HIL protocol over any link."""

from firmware_interface.emulator.config import EmulatorConfig, build_config, load_config
from firmware_interface.emulator.firmware import EmulatedBoard

__all__ = ["EmulatedBoard", "EmulatorConfig", "build_config", "load_config"]
