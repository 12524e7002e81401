"""Backstepping (the paper's §5.2 comparison), in the classical two-step form for each loop.

Position: e1 = ζ − ζ_c, α = ζ̇_c − k1 e1, e2 = ζ̇ − α,
          a = ζ̈_c − k1(e2 − k1 e1) − e1 − k2 e2    (V = ½|e1|² + ½|e2|², V̇ = −k1|e1|² − k2|e2|²)
Attitude: the same on η with J(η), C(η, η̇) of the nominal model:
          τ = J(η̈_s − k3(e2 − k3 e1) − e1 − k4 e2) + C η̇
No integral, no estimate of mass or disturbance: that is the point of the comparison.
"""

from __future__ import annotations

import math

import numpy as np

from firmware_interface.emulator.compiled import flight_code, shared_maths
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
from firmware_interface.emulator.control.differentiator import ThirdOrderDifferentiator, differentiate
from firmware_interface.emulator.control.plugin import ControllerGains, ControllerPlugin
from firmware_interface.emulator.geometry import coriolis_matrix, euler_rates, inertia_matrix_euler, mat_vec


@shared_maths
def position_step(pos_ned: np.ndarray, vel_ned: np.ndarray, pos_cmd: np.ndarray, vel_cmd: np.ndarray,
                  acc_cmd: np.ndarray, m: float, g: float, k1: float, k2: float) -> tuple[np.ndarray, np.ndarray]:
    """(thrust force NED in N, e2) of the position loop."""
    e1 = pos_ned - pos_cmd
    e2 = vel_ned - (vel_cmd - k1 * e1)
    accel = acc_cmd - k1 * (e2 - k1 * e1) - e1 - k2 * e2
    return m * (accel - g * E3), e2


@shared_maths
def attitude_step(eta: np.ndarray, eta_dot: np.ndarray, eta_cmd: np.ndarray, eta_s_dot: np.ndarray,
                  eta_s_ddot: np.ndarray, inertia: np.ndarray, k3: float, k4: float) -> np.ndarray:
    """Body torque (FRD, N·m) of the attitude loop, τ_η mapped through W⁻ᵀ."""
    a1 = angle_error(eta, eta_cmd)
    a2 = eta_dot - (eta_s_dot - k3 * a1)
    eta_ddot = eta_s_ddot - k3 * (a2 - k3 * a1) - a1 - k4 * a2
    tau = (mat_vec(inertia_matrix_euler(inertia, eta), eta_ddot)
           + mat_vec(coriolis_matrix(inertia, eta, eta_dot), eta_dot))
    return body_torque(tau, eta)


class BacksteppingGains(ControllerGains):
    k1: float = 2.0
    k2: float = 6.0
    k3: float = 30.0
    k4: float = 30.0
    differentiator_bandwidth: float = 100.0
    max_tilt: float = math.radians(35)


@flight_code
def backstepping_step(pos_ned: np.ndarray, vel_ned: np.ndarray, eta: np.ndarray, rates_frd: np.ndarray,
                      pos_cmd: np.ndarray, vel_cmd: np.ndarray, acc_cmd: np.ndarray, yaw_cmd: float, gains: np.ndarray,
                      g: float, m: float, z: np.ndarray, a_d: np.ndarray, b_d: np.ndarray, started: bool,
                      inertia: np.ndarray, dt: float) -> np.ndarray:
    """Both loops of one step (the differentiator advanced in place): `step_output` with e2 and u1 as internals;
    `gains` = (k1, k2, k3, k4, max tilt)."""
    force, e2 = position_step(pos_ned, vel_ned, pos_cmd, vel_cmd, acc_cmd, m, g, gains[0], gains[1])
    eta_cmd, thrust = command_from_force(force, yaw_cmd, gains[4], 0.2 * m * g, eta)
    differentiate(z, a_d, b_d, started, eta_cmd, dt)
    torque = attitude_step(eta, euler_rates(eta, rates_frd), eta_cmd, z[1], z[2], inertia, gains[2], gains[3])
    out = step_output(thrust, torque, eta_cmd, 4)
    out[INTERNALS:INTERNALS + 3] = e2
    out[INTERNALS + 3] = thrust
    return out


class Backstepping:
    name = "backstepping"
    internal_keys = ("e2_x", "e2_y", "e2_z", "thrust_n")

    def __init__(self, nominal: Nominal, gains: BacksteppingGains) -> None:
        self.nominal = nominal
        self.gains = gains
        self.differentiator = ThirdOrderDifferentiator(gains.differentiator_bandwidth)
        self.step_gains = GainValues(("k1", "k2", "k3", "k4", "max_tilt"))

    def reset(self) -> None:
        self.differentiator.reset()

    def update(self, state: VehicleState, setpoint: Setpoint, dt: float, adapt: bool = True) -> ControlOutput:
        out = backstepping_step(state.pos_ned, state.vel_ned, state.eta, state.rates_frd, setpoint.pos_ned,
                                setpoint.vel_ned, setpoint.acc_ned, setpoint.yaw, self.step_gains.of(self.gains),
                                self.nominal.g, self.nominal.mass, *self.differentiator.step_arrays(dt),
                                self.nominal.inertia, dt)
        return control_output(out, self.internal_keys)


PLUGIN = ControllerPlugin(Backstepping, BacksteppingGains, param_prefix="BS",
                          runtime_gains=("k1", "k2", "k3", "k4"))
