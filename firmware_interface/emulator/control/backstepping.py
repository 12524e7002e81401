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

from firmware_interface.emulator.control.base import (
    E3,
    ControlOutput,
    Nominal,
    Setpoint,
    VehicleState,
    angle_error,
    attitude_from_force,
    body_torque,
    collective_thrust,
)
from firmware_interface.emulator.control.differentiator import ThirdOrderDifferentiator
from firmware_interface.emulator.control.plugin import ControllerGains, ControllerPlugin
from firmware_interface.emulator.geometry import coriolis_matrix, inertia_matrix_euler


class BacksteppingGains(ControllerGains):
    k1: float = 2.0
    k2: float = 6.0
    k3: float = 30.0
    k4: float = 30.0
    differentiator_bandwidth: float = 100.0
    max_tilt: float = math.radians(35)


class Backstepping:
    name = "backstepping"
    internal_keys = ("e2_x", "e2_y", "e2_z", "thrust_n")

    def __init__(self, nominal: Nominal, gains: BacksteppingGains) -> None:
        self.nominal = nominal
        self.gains = gains
        self.differentiator = ThirdOrderDifferentiator(gains.differentiator_bandwidth)

    def reset(self) -> None:
        self.differentiator.reset()

    def update(self, state: VehicleState, setpoint: Setpoint, dt: float, adapt: bool = True) -> ControlOutput:
        k, g, m = self.gains, self.nominal.g, self.nominal.mass
        e1 = state.pos_ned - setpoint.pos_ned
        e2 = state.vel_ned - (setpoint.vel_ned - k.k1 * e1)
        accel = setpoint.acc_ned - k.k1 * (e2 - k.k1 * e1) - e1 - k.k2 * e2
        force = m * (accel - g * E3)
        roll_cmd, pitch_cmd, uz = attitude_from_force(force, setpoint.yaw, k.max_tilt, 0.2 * m * g)
        eta_cmd = np.array((roll_cmd, pitch_cmd, setpoint.yaw))
        thrust = collective_thrust(uz, state.eta[0], state.eta[1])

        _, eta_s_dot, eta_s_ddot = self.differentiator.update(eta_cmd, dt)
        eta_dot = state.eta_dot
        a1 = angle_error(state.eta, eta_cmd)
        a2 = eta_dot - (eta_s_dot - k.k3 * a1)
        eta_ddot = eta_s_ddot - k.k3 * (a2 - k.k3 * a1) - a1 - k.k4 * a2
        inertia = self.nominal.inertia
        tau = (inertia_matrix_euler(inertia, state.eta) @ eta_ddot
               + coriolis_matrix(inertia, state.eta, eta_dot) @ eta_dot)
        internals = {"e2_x": e2[0], "e2_y": e2[1], "e2_z": e2[2], "thrust_n": thrust}
        return ControlOutput(thrust, body_torque(tau, state.eta), eta_cmd, internals)


PLUGIN = ControllerPlugin(Backstepping, BacksteppingGains, param_prefix="BS",
                          runtime_gains=("k1", "k2", "k3", "k4"))
