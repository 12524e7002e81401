"""The attitude loop shared by SMARC and sliding mode PID: the paper's sliding mode law (eqs. 32–35)."""

from __future__ import annotations

import numpy as np

from firmware_interface.emulator.compiled import flight_code
from firmware_interface.emulator.control.base import VehicleState, angle_error, body_torque, sat
from firmware_interface.emulator.control.differentiator import ThirdOrderDifferentiator
from firmware_interface.emulator.geometry import coriolis_matrix, mat_vec


@flight_code
def sliding_mode_torque(eta: np.ndarray, eta_dot: np.ndarray, eta_cmd: np.ndarray, eta_s_dot: np.ndarray,
                        eta_s_ddot: np.ndarray, inertia: np.ndarray, j_s: np.ndarray, c2: float, lambda2: float,
                        epsilon: float, boundary: float) -> tuple[np.ndarray, np.ndarray]:
    """(τ_body FRD in N·m, S2) of the law below; `j_s` is the diagonal of J_s."""
    e = angle_error(eta, eta_cmd)
    e_dot = eta_dot - eta_s_dot
    s2 = e_dot + lambda2 * e  # eq. 32
    er_ddot = eta_s_ddot - lambda2 * e_dot  # d/dt of ė_r = η̇_s − λ2 e_η
    c_s = 0.9 * coriolis_matrix(inertia, eta, eta_dot)
    tau = j_s * er_ddot + mat_vec(c_s, eta_dot) - c2 * s2 - epsilon * sat(s2, boundary)
    return body_torque(tau, eta), s2


class SlidingModeAttitude:
    """τ = J_s ë_r + C_s η̇ − c2 S2 − ε sat(S2 / φ), with S2 = ė_η + λ2 e_η and ė_r = η̇_s − λ2 e_η.

    J_s = diag(Ix, Iy + Iz, Ix + Iy + Iz) and C_s = 0.9 C are the paper's nominal model (eq. 35);
    η̇_s, η̈_s come from a third-order differentiator of the commanded angles.
    """

    def __init__(self, inertia: np.ndarray, c2: float, lambda2: float, epsilon: float, boundary: float,
                 differentiator_bandwidth: float) -> None:
        ix, iy, iz = inertia
        self.inertia = np.asarray(inertia, float)
        self.j_s = np.array((ix, iy + iz, ix + iy + iz))  # the diagonal of J_s
        self.c2, self.lambda2, self.epsilon, self.boundary = c2, lambda2, epsilon, boundary
        self.differentiator = ThirdOrderDifferentiator(differentiator_bandwidth)
        self.s2 = np.zeros(3)

    def reset(self) -> None:
        self.differentiator.reset()
        self.s2 = np.zeros(3)

    def update(self, state: VehicleState, eta_cmd: np.ndarray, dt: float) -> np.ndarray:
        """Body torque (FRD, N·m) that drives η to η_cmd."""
        _, eta_s_dot, eta_s_ddot = self.differentiator.update(eta_cmd, dt)
        torque, self.s2 = sliding_mode_torque(state.eta, state.eta_dot, eta_cmd, eta_s_dot, eta_s_ddot, self.inertia,
                                              self.j_s, self.c2, self.lambda2, self.epsilon, self.boundary)
        return torque
