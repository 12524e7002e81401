"""The paper's three controllers behind one interface: state + setpoint + dt -> thrust and body torques."""

from __future__ import annotations

from firmware_interface.emulator.control.base import Controller, ControlOutput, Nominal, Setpoint, VehicleState

__all__ = ["ControlOutput", "Controller", "Nominal", "Setpoint", "VehicleState"]
