"""A template for a new controller: copy this module, rename, write the step, register `PLUGIN` in
`control/registry.py`. It is a working cascaded PD (not one of the paper's controllers, and not
registered); tests/test_controller_conformance.py checks it as it checks every registered one.

The shape every controller has: the law is one `flight_code` function (compiled by numba: numbers and float64
arrays in, its state arrays advanced in place, `step_output` out), and `update` only gathers its arguments and
wraps the output. A law spread over several calls from Python costs ~20 µs a step more, on the lockstep round
trip. The helpers it calls (`command_from_force`, `angle_error`, ...) are `shared_maths`.

Position: a = ζ̈_c − kp (ζ − ζ_c) − kd (ζ̇ − ζ̇_c), thrust force m (a − g e3) in NED
Attitude: the tilt and collective of that force (base.command_from_force), then
          τ = J (−kp_att e_η − kd_att η̇) in Euler coordinates, applied as body torques.
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import Field

from firmware_interface.emulator.compiled import flight_code
from firmware_interface.emulator.control.base import (
    E3,
    INTERNALS,
    ControlOutput,
    GainValues,
    Nominal,
    Setpoint,
    VehicleState,
    angle_error,
    body_torque,
    command_from_force,
    control_output,
    step_output,
)
from firmware_interface.emulator.control.plugin import ControllerGains, ControllerPlugin
from firmware_interface.emulator.geometry import euler_rates


class TemplateGains(ControllerGains):
    """Every gain with its unit; pydantic bounds reject a value that cannot fly."""

    kp: float = Field(4.0, gt=0, description="position gain, 1/s²")
    kd: float = Field(3.0, gt=0, description="velocity gain, 1/s")
    kp_att: float = Field(100.0, gt=0, description="attitude gain, 1/s² (ω_n = 10 rad/s)")
    kd_att: float = Field(20.0, gt=0, description="attitude rate gain, 1/s (ζ = 1)")
    max_tilt: float = Field(math.radians(35), gt=0, lt=math.pi / 2)


@flight_code
def cascaded_pd_step(pos_ned: np.ndarray, vel_ned: np.ndarray, eta: np.ndarray, rates_frd: np.ndarray,
                     pos_cmd: np.ndarray, vel_cmd: np.ndarray, acc_cmd: np.ndarray, yaw_cmd: float, gains: np.ndarray,
                     g: float, m: float, inertia: np.ndarray) -> np.ndarray:
    """Both loops: `step_output` with the position error and u1 as internals; `gains` in STEP_GAINS' order."""
    kp, kd, kp_att, kd_att, max_tilt = gains[0], gains[1], gains[2], gains[3], gains[4]
    e = pos_ned - pos_cmd
    accel = acc_cmd - kp * e - kd * (vel_ned - vel_cmd)
    eta_cmd, thrust = command_from_force(m * (accel - g * E3), yaw_cmd, max_tilt, 0.2 * m * g, eta)
    tau = inertia * (-kp_att * angle_error(eta, eta_cmd) - kd_att * euler_rates(eta, rates_frd))
    out = step_output(thrust, body_torque(tau, eta), eta_cmd, 4)
    out[INTERNALS:INTERNALS + 3] = e
    out[INTERNALS + 3] = thrust
    return out


STEP_GAINS = ("kp", "kd", "kp_att", "kd_att", "max_tilt")


class CascadedPd:
    name = "template"  # as scenarios and the CLI name it; its first 10 characters label DEBUG_FLOAT_ARRAY
    internal_keys = ("e_x", "e_y", "e_z", "thrust_n")  # published in this order, at most 58

    def __init__(self, nominal: Nominal, gains: TemplateGains) -> None:
        self.nominal = nominal
        self.gains = gains  # read in every update: a PARAM_SET of a runtime gain takes effect at once
        self.step_gains = GainValues(STEP_GAINS)

    def reset(self) -> None:
        """No state to clear: a controller with integrators or estimates resets them here."""

    def update(self, state: VehicleState, setpoint: Setpoint, dt: float, adapt: bool = True) -> ControlOutput:
        out = cascaded_pd_step(state.pos_ned, state.vel_ned, state.eta, state.rates_frd, setpoint.pos_ned,
                               setpoint.vel_ned, setpoint.acc_ned, setpoint.yaw, self.step_gains.of(self.gains),
                               self.nominal.g, self.nominal.mass, self.nominal.inertia)
        return control_output(out, self.internal_keys)


PLUGIN = ControllerPlugin(CascadedPd, TemplateGains, param_prefix="TPL", runtime_gains=("kp", "kd"))
