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

from firmware_interface.emulator.compiled import flight_code, shared_maths
from firmware_interface.emulator.control.attitude import SlidingModeAttitude, sliding_mode_attitude
from firmware_interface.emulator.control.base import (
    E3,
    INTERNALS,
    ControlOutput,
    GainValues,
    Nominal,
    Setpoint,
    VehicleState,
    command_from_force,
    control_output,
    step_output,
)
from firmware_interface.emulator.control.plugin import ControllerGains, ControllerPlugin
from firmware_interface.emulator.geometry import dot


@shared_maths
def position_law(pos_ned: np.ndarray, vel_ned: np.ndarray, pos_cmd: np.ndarray, vel_cmd: np.ndarray,
                 acc_cmd: np.ndarray, m_hat: float, d_hat: np.ndarray, s1_filtered: np.ndarray, g: float, c1: float,
                 lambda1: float, gamma1: float, gamma2: float, d_max: float, mass_min: float, mass_max: float,
                 filter_s: float, deadzone: float, adapt: bool, dt: float) -> tuple[np.ndarray, np.ndarray, float]:
    """(u_s, S1, m̂) of eqs. 7–9, with d̂_s and the filtered S1 advanced in place (eqs. 13, 14, 18)."""
    e = pos_ned - pos_cmd
    e_dot = vel_ned - vel_cmd
    s1 = e_dot + lambda1 * e  # eq. 7
    u_bar = -g * E3 + acc_cmd - lambda1 * e_dot - c1 * s1  # eq. 9
    force = m_hat * u_bar - d_hat  # eq. 8

    alpha = min(dt / filter_s, 1.0) if filter_s > 0 else 1.0
    s1_filtered += alpha * (s1 - s1_filtered)
    if adapt and np.sqrt(dot(s1_filtered, s1_filtered)) > deadzone:
        d_hat[:] = np.clip(d_hat + dt * gamma1 * s1_filtered, -d_max, d_max)  # eq. 13
        m_rate = -gamma2 * dot(s1_filtered, u_bar)  # eq. 14
        if (m_hat >= mass_max and m_rate > 0) or (m_hat <= mass_min and m_rate < 0):
            m_rate = 0.0  # projection (eq. 18)
        m_hat = min(max(m_hat + dt * m_rate, mass_min), mass_max)
    return force, s1, m_hat


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


# the gains the compiled step reads, in its order
STEP_GAINS = ("c1", "lambda1", "gamma1", "gamma2", "d_max", "mass_min", "mass_max", "adaptation_filter_s",
              "adaptation_deadzone", "max_tilt")


@flight_code
def smarc_step(pos_ned: np.ndarray, vel_ned: np.ndarray, eta: np.ndarray, rates_frd: np.ndarray, pos_cmd: np.ndarray,
               vel_cmd: np.ndarray, acc_cmd: np.ndarray, yaw_cmd: float, gains: np.ndarray, g: float, m_hat: float,
               d_hat: np.ndarray, s1_filtered: np.ndarray, adapt: bool, z: np.ndarray, a_d: np.ndarray,
               b_d: np.ndarray, started: bool, inertia: np.ndarray, j_s: np.ndarray, law: np.ndarray,
               dt: float) -> np.ndarray:
    """One step of the position law (d̂_s, the filtered S1 and the differentiator advanced in place), the attitude
    command, the attitude law: `step_output` with m̂, d̂_s, S1, S2 and u1 as internals."""
    force, s1, m_hat = position_law(pos_ned, vel_ned, pos_cmd, vel_cmd, acc_cmd, m_hat, d_hat, s1_filtered, g,
                                    gains[0], gains[1], gains[2], gains[3], gains[4], gains[5], gains[6], gains[7],
                                    gains[8], adapt, dt)
    eta_cmd, thrust = command_from_force(force, yaw_cmd, gains[9], 0.2 * m_hat * g, eta)
    torque, s2 = sliding_mode_attitude(eta, rates_frd, eta_cmd, z, a_d, b_d, started, inertia, j_s, law, dt)
    out = step_output(thrust, torque, eta_cmd, 11)
    out[INTERNALS] = m_hat
    out[INTERNALS + 1:INTERNALS + 4] = d_hat
    out[INTERNALS + 4:INTERNALS + 7] = s1
    out[INTERNALS + 7:INTERNALS + 10] = s2
    out[INTERNALS + 10] = thrust
    return out


class Smarc:
    name = "smarc"
    internal_keys = ("m_hat", "d_hat_x", "d_hat_y", "d_hat_z", "s1_x", "s1_y", "s1_z", "s2_x", "s2_y", "s2_z",
                     "thrust_n")

    def __init__(self, nominal: Nominal, gains: SmarcGains) -> None:
        self.nominal = nominal
        self.gains = gains
        self.attitude = SlidingModeAttitude(nominal.inertia * gains.model_scale, gains.c2, gains.lambda2,
                                            gains.epsilon, gains.boundary_layer, gains.differentiator_bandwidth)
        self.step_gains = GainValues(STEP_GAINS)
        self.reset()

    def reset(self) -> None:
        self.m_hat = self.gains.mass_initial if self.gains.mass_initial is not None else self.nominal.mass
        self.d_hat = np.zeros(3)
        self.s1_filtered = np.zeros(3)
        self.attitude.reset()

    def update(self, state: VehicleState, setpoint: Setpoint, dt: float, adapt: bool = True) -> ControlOutput:
        attitude = self.attitude
        out = smarc_step(state.pos_ned, state.vel_ned, state.eta, state.rates_frd, setpoint.pos_ned,
                         setpoint.vel_ned, setpoint.acc_ned, setpoint.yaw, self.step_gains.of(self.gains),
                         self.nominal.g, self.m_hat, self.d_hat, self.s1_filtered, adapt,
                         *attitude.differentiator.step_arrays(dt), attitude.inertia, attitude.j_s, attitude.law, dt)
        self.m_hat = float(out[INTERNALS])
        return control_output(out, self.internal_keys)


PLUGIN = ControllerPlugin(Smarc, SmarcGains, param_prefix="SMARC",
                          runtime_gains=("c1", "lambda1", "gamma1", "gamma2", "d_max", "mass_min", "mass_max"))
