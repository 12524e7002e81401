"""A template for a new controller: copy this module, rename, write `update`, register `PLUGIN` in
`control/registry.py`. It is a working cascaded PD (not one of the paper's controllers, and not
registered); tests/test_controller_conformance.py checks it as it checks every registered one.

Position: a = ζ̈_c − kp (ζ − ζ_c) − kd (ζ̇ − ζ̇_c), thrust force m (a − g e3) in NED
Attitude: the tilt and collective of that force (base.command_from_force), then
          τ = J (−kp_att e_η − kd_att η̇) in Euler coordinates, applied as body torques.
"""

from __future__ import annotations

import math

from pydantic import Field

from firmware_interface.emulator.control.base import (
    E3,
    ControlOutput,
    Nominal,
    Setpoint,
    VehicleState,
    angle_error,
    body_torque,
    command_from_force,
)
from firmware_interface.emulator.control.plugin import ControllerGains, ControllerPlugin


class TemplateGains(ControllerGains):
    """Every gain with its unit; pydantic bounds reject a value that cannot fly."""

    kp: float = Field(4.0, gt=0, description="position gain, 1/s²")
    kd: float = Field(3.0, gt=0, description="velocity gain, 1/s")
    kp_att: float = Field(100.0, gt=0, description="attitude gain, 1/s² (ω_n = 10 rad/s)")
    kd_att: float = Field(20.0, gt=0, description="attitude rate gain, 1/s (ζ = 1)")
    max_tilt: float = Field(math.radians(35), gt=0, lt=math.pi / 2)


class CascadedPd:
    name = "template"  # as scenarios and the CLI name it; its first 10 characters label DEBUG_FLOAT_ARRAY
    internal_keys = ("e_x", "e_y", "e_z", "thrust_n")  # published in this order, at most 58

    def __init__(self, nominal: Nominal, gains: TemplateGains) -> None:
        self.nominal = nominal
        self.gains = gains  # read in every update: a PARAM_SET of a runtime gain takes effect at once

    def reset(self) -> None:
        """No state to clear: a controller with integrators or estimates resets them here."""

    def update(self, state: VehicleState, setpoint: Setpoint, dt: float, adapt: bool = True) -> ControlOutput:
        k, m, g = self.gains, self.nominal.mass, self.nominal.g
        e = state.pos_ned - setpoint.pos_ned
        accel = setpoint.acc_ned - k.kp * e - k.kd * (state.vel_ned - setpoint.vel_ned)
        eta_cmd, thrust = command_from_force(m * (accel - g * E3), setpoint.yaw, k.max_tilt, 0.2 * m * g, state.eta)
        tau = self.nominal.inertia * (-k.kp_att * angle_error(state.eta, eta_cmd) - k.kd_att * state.eta_dot)
        internals = {"e_x": e[0], "e_y": e[1], "e_z": e[2], "thrust_n": thrust}
        return ControlOutput(thrust, body_torque(tau, state.eta), eta_cmd, internals)


PLUGIN = ControllerPlugin(CascadedPd, TemplateGains, param_prefix="TPL", runtime_gains=("kp", "kd"))
