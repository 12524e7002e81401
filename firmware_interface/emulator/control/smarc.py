"""SMARC: the paper's sliding mode adaptive robust controller (§3.2–3.3).

Position loop (NED form of eqs. 6–18):
    e_s = ζ − ζ_c,  S1 = ė_s + λ1 e_s                                    (7)
    ū_s = −g e3 + ζ̈_c − λ1 ė_s − c1 S1                                  (9, gravity down in NED)
    u_s = m̂ ū_s − d̂_s    (the thrust force in NED)                       (8)
    d̂̇_s = γ1 S1,   m̂̇ = Proj(−γ2 S1ᵀ ū_s) within [m_min, m_max]         (13, 14, 18)
Optional robustness for noisy sensors (off by default, i.e. the paper's law): S1 in the adaptive
laws low-passed (`adaptation_filter_s`) and a dead-zone (`adaptation_deadzone`).
With u_s = −u1·R·e3 the Lyapunov argument of the paper carries over unchanged:
Ṡ1 = (−m̃ ū_s + d̃)/m − c1 S1. Attitude: eqs. 26–29 and 32–35 (SlidingModeAttitude).
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import Field

from firmware_interface.emulator.control.attitude import SlidingModeAttitude
from firmware_interface.emulator.control.base import (
    E3,
    ControlOutput,
    Nominal,
    Setpoint,
    VehicleState,
    attitude_from_force,
    collective_thrust,
)
from firmware_interface.emulator.control.plugin import ControllerGains, ControllerPlugin


class SmarcGains(ControllerGains):
    """Defaults: the paper's §4 gains (c1 = 6, λ1 = 2, γ1 = 0.8, γ2 = 0.3, c2 = 8, ε = 0.3, λ2 = 60, φ = 0.3)."""

    c1: float = 6.0
    lambda1: float = 2.0
    gamma1: float = 0.8
    gamma2: float = 0.3
    c2: float = 8.0
    epsilon: float = 0.3
    lambda2: float = 60.0
    boundary_layer: float = 0.3
    mass_min: float = Field(0.2, gt=0, description="projection bounds of m̂ (eq. 18)")
    mass_max: float = Field(8.0, gt=0)
    mass_initial: float | None = Field(None, description="m̂(0); default the nominal mass")
    d_max: float = Field(20.0, gt=0, description="bound on each component of d̂_s, N")
    adaptation_filter_s: float = Field(0.0, ge=0,
                                       description="low-pass of S1 driving the adaptive laws (0 = the paper's law)")
    adaptation_deadzone: float = Field(0.0, ge=0, description="no adaptation while |S1| (filtered) is below this, m/s")
    differentiator_bandwidth: float = Field(100.0, gt=0, description="rad/s")
    model_scale: float = Field(1.0, gt=0, description="J_s and C_s (eq. 35) are this times the nominal model's: "
                               "the attitude law's sensitivity to a wrong inertia")
    max_tilt: float = Field(math.radians(35), gt=0, lt=math.pi / 2)


class Smarc:
    name = "smarc"
    internal_keys = ("m_hat", "d_hat_x", "d_hat_y", "d_hat_z", "s1_x", "s1_y", "s1_z", "s2_x", "s2_y", "s2_z",
                     "thrust_n")

    def __init__(self, nominal: Nominal, gains: SmarcGains) -> None:
        self.nominal = nominal
        self.gains = gains
        self.attitude = SlidingModeAttitude(nominal.inertia * gains.model_scale, gains.c2, gains.lambda2,
                                            gains.epsilon, gains.boundary_layer, gains.differentiator_bandwidth)
        self.reset()

    def reset(self) -> None:
        self.m_hat = self.gains.mass_initial if self.gains.mass_initial is not None else self.nominal.mass
        self.d_hat = np.zeros(3)
        self.s1 = np.zeros(3)
        self.s1_filtered = np.zeros(3)
        self.attitude.reset()

    def update(self, state: VehicleState, setpoint: Setpoint, dt: float, adapt: bool = True) -> ControlOutput:
        k, g = self.gains, self.nominal.g
        e = state.pos_ned - setpoint.pos_ned
        e_dot = state.vel_ned - setpoint.vel_ned
        self.s1 = e_dot + k.lambda1 * e
        u_bar = -g * E3 + setpoint.acc_ned - k.lambda1 * e_dot - k.c1 * self.s1
        force = self.m_hat * u_bar - self.d_hat

        alpha = min(dt / k.adaptation_filter_s, 1.0) if k.adaptation_filter_s > 0 else 1.0
        self.s1_filtered += alpha * (self.s1 - self.s1_filtered)
        s1 = self.s1_filtered
        if adapt and float(np.linalg.norm(s1)) > k.adaptation_deadzone:
            self.d_hat = np.clip(self.d_hat + dt * k.gamma1 * s1, -k.d_max, k.d_max)
            m_rate = -k.gamma2 * float(s1 @ u_bar)
            if (self.m_hat >= k.mass_max and m_rate > 0) or (self.m_hat <= k.mass_min and m_rate < 0):
                m_rate = 0.0  # projection (eq. 18)
            self.m_hat = min(max(self.m_hat + dt * m_rate, k.mass_min), k.mass_max)

        roll_cmd, pitch_cmd, uz = attitude_from_force(force, setpoint.yaw, k.max_tilt, 0.2 * self.m_hat * g)
        eta_cmd = np.array((roll_cmd, pitch_cmd, setpoint.yaw))
        thrust = collective_thrust(uz, state.eta[0], state.eta[1])
        torque = self.attitude.update(state, eta_cmd, dt)
        internals = {"m_hat": self.m_hat, "d_hat_x": self.d_hat[0], "d_hat_y": self.d_hat[1],
                     "d_hat_z": self.d_hat[2], "s1_x": self.s1[0], "s1_y": self.s1[1], "s1_z": self.s1[2],
                     "s2_x": self.attitude.s2[0], "s2_y": self.attitude.s2[1], "s2_z": self.attitude.s2[2],
                     "thrust_n": thrust}
        return ControlOutput(thrust, torque, eta_cmd, internals)


PLUGIN = ControllerPlugin(Smarc, SmarcGains, param_prefix="SMARC",
                          runtime_gains=("c1", "lambda1", "gamma1", "gamma2", "d_max", "mass_min", "mass_max"))
