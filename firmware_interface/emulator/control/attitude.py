"""The attitude loop shared by SMARC and sliding mode PID: the paper's sliding mode law (eqs. 32–35)."""

from __future__ import annotations

import numpy as np

from firmware_interface.emulator.compiled import shared_maths
from firmware_interface.emulator.control.base import angle_error, body_torque, sat
from firmware_interface.emulator.control.differentiator import ThirdOrderDifferentiator, differentiate
from firmware_interface.emulator.geometry import coriolis_matrix, euler_rates, mat_vec


@shared_maths
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


@shared_maths
def sliding_mode_attitude(eta: np.ndarray, rates_frd: np.ndarray, eta_cmd: np.ndarray, z: np.ndarray, a_d: np.ndarray,
                          b_d: np.ndarray, started: bool, inertia: np.ndarray, j_s: np.ndarray, law: np.ndarray,
                          dt: float) -> tuple[np.ndarray, np.ndarray]:
    """(τ_body, S2) for η_cmd: its derivatives from the differentiator (z, A_d, B_d, advanced here), then the law;
    `law` = (c2, λ2, ε, φ)."""
    differentiate(z, a_d, b_d, started, eta_cmd, dt)
    return sliding_mode_torque(eta, euler_rates(eta, rates_frd), eta_cmd, z[1], z[2], inertia, j_s, law[0], law[1],
                               law[2], law[3])


class SlidingModeAttitude:
    """τ = J_s ë_r + C_s η̇ − c2 S2 − ε sat(S2 / φ), with S2 = ė_η + λ2 e_η and ė_r = η̇_s − λ2 e_η.

    J_s = diag(Ix, Iy + Iz, Ix + Iy + Iz) and C_s = 0.9 C are the paper's nominal model (eq. 35);
    η̇_s, η̈_s come from a third-order differentiator of the commanded angles. This holds the law's constants and
    the differentiator; a controller's compiled step calls `sliding_mode_attitude` with them.
    """

    def __init__(self, inertia: np.ndarray, c2: float, lambda2: float, epsilon: float, boundary: float,
                 differentiator_bandwidth: float) -> None:
        ix, iy, iz = inertia
        self.inertia = np.asarray(inertia, float)
        self.j_s = np.array((ix, iy + iz, ix + iy + iz))  # the diagonal of J_s
        self.law = np.array((c2, lambda2, epsilon, boundary))
        self.differentiator = ThirdOrderDifferentiator(differentiator_bandwidth)

    def reset(self) -> None:
        self.differentiator.reset()
