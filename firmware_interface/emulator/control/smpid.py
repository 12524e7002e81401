"""Sliding mode PID (the paper's §5.1 comparison): PID on the fully actuated channels (altitude, yaw),
sliding mode on the underactuated ones (x, y through roll and pitch).

The paper gives no gains or equations for it; this is our design, stated in the docs:
    z:      a_z = z̈_c − kp e_z − kd ė_z − ki ∫e_z
    x, y:   S = ė + λ e,  a_xy = ζ̈_c − λ ė − c S − ε sat(S/φ)
    roll, pitch: the paper's sliding mode attitude law (eqs. 32–35)
    yaw:    PID on the yaw error, τ_ψ = Iz_s(−kp e_ψ − kd ė_ψ − ki ∫e_ψ)
No mass or disturbance estimate: the integral carries a constant load offset.
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
    angle_error,
    command_from_force,
    control_output,
    sat,
    step_output,
)
from firmware_interface.emulator.control.plugin import ControllerGains, ControllerPlugin


@shared_maths
def position_law(pos_ned: np.ndarray, vel_ned: np.ndarray, pos_cmd: np.ndarray, vel_cmd: np.ndarray,
                 acc_cmd: np.ndarray, z_integral: float, m: float, g: float, kp_z: float, kd_z: float, ki_z: float,
                 integral_limit: float, lambda_xy: float, c_xy: float, epsilon_xy: float, boundary: float,
                 adapt: bool, dt: float) -> tuple[np.ndarray, np.ndarray, float]:
    """(thrust force NED in N, S of x and y, ∫e_z): PID on z, sliding mode on x and y."""
    e = pos_ned - pos_cmd
    e_dot = vel_ned - vel_cmd
    if adapt:
        z_integral = min(max(z_integral + e[2] * dt, -integral_limit), integral_limit)
    a_z = acc_cmd[2] - kp_z * e[2] - kd_z * e_dot[2] - ki_z * z_integral
    s_xy = e_dot[:2] + lambda_xy * e[:2]
    a_xy = acc_cmd[:2] - lambda_xy * e_dot[:2] - c_xy * s_xy - epsilon_xy * sat(s_xy, boundary)
    force = m * (np.array((a_xy[0], a_xy[1], a_z)) - g * E3)
    return force, s_xy, z_integral


class SmpidGains(ControllerGains):
    kp_z: float = 12.0
    kd_z: float = 7.0
    ki_z: float = 6.0
    # |∫e_z| ≤ integral_limit (m·s): with ki_z = 6 the integral then corrects at most 12 m/s² (~1.2 g), so a
    # vehicle up to ~2.2× its nominal mass is carried; a scenario lifts it with board.config.gains.smpid
    integral_limit: float = Field(2.0, gt=0, description="clamp of the altitude integral, m·s")
    lambda_xy: float = 2.0
    c_xy: float = 6.0
    # the switching gain must exceed the matched disturbance per unit mass for S to reach zero:
    # 1 m/s² bounds the paper's d_s at its 1 kg nominal and a 4 m/s gust on the inspection quad's
    # 0.25 N·s/m drag; 20 % reaching margin on top
    epsilon_xy: float = 1.2
    boundary_layer: float = 0.3
    c2: float = 8.0
    lambda2: float = 60.0
    epsilon_att: float = 0.3
    # yaw PID per unit of nominal Iz: ω_n = 20 rad/s, ζ = 0.9, integral at ω_n², comparable to the
    # other attitude loops (the paper gives no gains); the inspection preset softens it for its rotors
    kp_yaw: float = 400.0
    kd_yaw: float = 36.0
    ki_yaw: float = 400.0
    yaw_integral_limit: float = Field(0.5, gt=0, description="clamp of the yaw integral, rad·s")
    differentiator_bandwidth: float = 100.0
    max_tilt: float = math.radians(35)


# the gains the compiled step reads, in its order
STEP_GAINS = ("kp_z", "kd_z", "ki_z", "integral_limit", "lambda_xy", "c_xy", "epsilon_xy", "boundary_layer", "max_tilt",
              "kp_yaw", "kd_yaw", "ki_yaw", "yaw_integral_limit")


@flight_code
def smpid_step(pos_ned: np.ndarray, vel_ned: np.ndarray, eta: np.ndarray, rates_frd: np.ndarray, pos_cmd: np.ndarray,
               vel_cmd: np.ndarray, acc_cmd: np.ndarray, yaw_cmd: float, gains: np.ndarray, g: float, m: float,
               integrals: np.ndarray, adapt: bool, z: np.ndarray, a_d: np.ndarray, b_d: np.ndarray, started: bool,
               inertia: np.ndarray, j_s: np.ndarray, law: np.ndarray, dt: float) -> np.ndarray:
    """One step: the position law, the attitude command, the sliding mode attitude law with yaw replaced by a PID
    (`integrals` = (∫e_z, ∫e_yaw) and the differentiator advanced in place); `step_output` with S of x and y,
    ∫e_z, S2 of roll and pitch and u1 as internals."""
    force, s_xy, integrals[0] = position_law(pos_ned, vel_ned, pos_cmd, vel_cmd, acc_cmd, integrals[0], m, g, gains[0],
                                             gains[1], gains[2], gains[3], gains[4], gains[5], gains[6], gains[7],
                                             adapt, dt)
    eta_cmd, thrust = command_from_force(force, yaw_cmd, gains[8], 0.2 * m * g, eta)
    torque, s2 = sliding_mode_attitude(eta, rates_frd, eta_cmd, z, a_d, b_d, started, inertia, j_s, law, dt)
    e_yaw = angle_error(eta, eta_cmd)[2]
    if adapt:
        integrals[1] = min(max(integrals[1] + e_yaw * dt, -gains[12]), gains[12])
    torque[2] = inertia[2] * (-gains[9] * e_yaw - gains[10] * rates_frd[2] - gains[11] * integrals[1])
    out = step_output(thrust, torque, eta_cmd, 6)
    out[INTERNALS:INTERNALS + 2] = s_xy
    out[INTERNALS + 2] = integrals[0]
    out[INTERNALS + 3:INTERNALS + 5] = s2[:2]
    out[INTERNALS + 5] = thrust
    return out


class SlidingModePid:
    name = "smpid"
    internal_keys = ("s_x", "s_y", "z_integral", "s2_x", "s2_y", "thrust_n")

    def __init__(self, nominal: Nominal, gains: SmpidGains) -> None:
        self.nominal = nominal
        self.gains = gains
        self.attitude = SlidingModeAttitude(nominal.inertia, gains.c2, gains.lambda2, gains.epsilon_att,
                                            gains.boundary_layer, gains.differentiator_bandwidth)
        self.step_gains = GainValues(STEP_GAINS)
        self.reset()

    def reset(self) -> None:
        self.integrals = np.zeros(2)  # altitude (m·s) and yaw (rad·s)
        self.attitude.reset()

    def update(self, state: VehicleState, setpoint: Setpoint, dt: float, adapt: bool = True) -> ControlOutput:
        attitude = self.attitude
        out = smpid_step(state.pos_ned, state.vel_ned, state.eta, state.rates_frd, setpoint.pos_ned,
                         setpoint.vel_ned, setpoint.acc_ned, setpoint.yaw, self.step_gains.of(self.gains),
                         self.nominal.g, self.nominal.mass, self.integrals, adapt,
                         *attitude.differentiator.step_arrays(dt), attitude.inertia, attitude.j_s, attitude.law, dt)
        return control_output(out, self.internal_keys)


PLUGIN = ControllerPlugin(SlidingModePid, SmpidGains, param_prefix="SMPID",
                          runtime_gains=("kp_z", "kd_z", "ki_z", "integral_limit", "lambda_xy", "c_xy", "epsilon_xy"))
