"""Attitude maths for the flight code: quaternions, ZYX Euler angles, and the paper's J(η), C(η, η̇).

Plain Python where the bench calls them; compiled into the emulator's flight code that calls them
(`compiled.shared_maths`), so each stays within what numba compiles.
"""

from __future__ import annotations

import math

import numpy as np

from firmware_interface.emulator.compiled import shared_maths


@shared_maths
def quat_to_euler(q: np.ndarray) -> np.ndarray:
    """ZYX (roll, pitch, yaw) of a body FRD -> NED quaternion (w, x, y, z)."""
    w, x, y, z = q
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.array((roll, pitch, yaw))


@shared_maths
def euler_to_quat(roll: float, pitch: float, yaw: float) -> np.ndarray:
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return np.array((cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
                     cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy))


@shared_maths
def quat_to_dcm(q: np.ndarray) -> np.ndarray:
    """R rotating body FRD vectors into NED."""
    w, x, y, z = q
    return np.array((
        (1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)),
        (2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)),
        (2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)),
    ))


@shared_maths
def quat_multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return np.array((aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw))


@shared_maths
def euler_rate_matrix(roll: float, pitch: float) -> np.ndarray:
    """W with ω_body = W(η)·η̇ (ZYX)."""
    sr, cr, sp, cp = math.sin(roll), math.cos(roll), math.sin(pitch), math.cos(pitch)
    return np.array(((1.0, 0.0, -sp), (0.0, cr, sr * cp), (0.0, -sr, cr * cp)))


@shared_maths
def euler_rates(eta: np.ndarray, rates_frd: np.ndarray) -> np.ndarray:
    """η̇ = W⁻¹ ω in closed form (ZYX)."""
    sr, cr = math.sin(eta[0]), math.cos(eta[0])
    cp, tp = math.cos(eta[1]), math.tan(eta[1])
    p, q, r = rates_frd
    return np.array((p + (sr * q + cr * r) * tp, cr * q - sr * r, (sr * q + cr * r) / cp))


@shared_maths
def body_from_euler_torque(eta: np.ndarray, tau_euler: np.ndarray) -> np.ndarray:
    """τ_body = W⁻ᵀ τ_η in closed form: the rotors' torque for a generalised torque in η."""
    sr, cr = math.sin(eta[0]), math.cos(eta[0])
    cp, tp = math.cos(eta[1]), math.tan(eta[1])
    a, b, c = tau_euler
    return np.array((a, sr * tp * a + cr * b + sr / cp * c, cr * tp * a - sr * b + cr / cp * c))


@shared_maths
def wrap_pi(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi


@shared_maths
def coriolis_matrix(inertia: np.ndarray, eta: np.ndarray, eta_dot: np.ndarray) -> np.ndarray:
    """The paper's C(η, η̇) (eq. 5), with its two printed typos corrected (psi -> psi_dot in C12,
    the missing cos²θ in C31), so that J(η)η̈ + C η̇ = Wᵀ τ_body holds exactly."""
    ix, iy, iz = inertia
    roll, pitch, _ = eta
    rd, pd, yd = eta_dot
    sr, cr, sp, cp = math.sin(roll), math.cos(roll), math.sin(pitch), math.cos(pitch)
    c12 = (iy - iz) * (pd * sr * cr + yd * sr * sr * cp) - (iy - iz) * yd * cr * cr * cp - ix * yd * cp
    c13 = (iz - iy) * yd * sr * cr * cp * cp
    c22 = (iz - iy) * rd * sr * cr
    c23 = -ix * yd * cp * sp + iy * yd * cp * sp * sr * sr + iz * yd * cp * sp * cr * cr
    c31 = (iy - iz) * yd * sr * cr * cp * cp - ix * pd * cp
    c32 = ((iz - iy) * (pd * sr * cr * sp + rd * sr * sr * cp) + (iy - iz) * rd * cr * cr * cp
           + ix * yd * cp * sp - iy * yd * sr * sr * cp * sp - iz * yd * cr * cr * cp * sp)
    c33 = ((iy - iz) * rd * sr * cr * cp * cp - iy * pd * sr * sr * cp * sp - iz * pd * cr * cr * cp * sp
           + ix * pd * cp * sp)
    return np.array(((0.0, c12, c13), (-c12, c22, c23), (c31, c32, c33)))


@shared_maths
def inertia_matrix_euler(inertia: np.ndarray, eta: np.ndarray) -> np.ndarray:
    """J(η) = Wᵀ I W (eq. 4), with I = diag(Ix, Iy, Iz)."""
    w = euler_rate_matrix(eta[0], eta[1])
    j = np.zeros((3, 3))
    for row in range(3):
        for col in range(3):
            j[row, col] = (w[0, row] * inertia[0] * w[0, col] + w[1, row] * inertia[1] * w[1, col]
                           + w[2, row] * inertia[2] * w[2, col])
    return j


@shared_maths
def dot(a: np.ndarray, b: np.ndarray) -> float:
    """a · b of two 3-vectors."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@shared_maths
def mat_vec(m: np.ndarray, v: np.ndarray) -> np.ndarray:
    """M v for a 3x3 M."""
    return np.array((m[0, 0] * v[0] + m[0, 1] * v[1] + m[0, 2] * v[2], m[1, 0] * v[0] + m[1, 1] * v[1] + m[1, 2] * v[2],
                     m[2, 0] * v[0] + m[2, 1] * v[1] + m[2, 2] * v[2]))


@shared_maths
def mat_t_vec(m: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Mᵀ v for a 3x3 M (a rotation's inverse)."""
    return np.array((m[0, 0] * v[0] + m[1, 0] * v[1] + m[2, 0] * v[2], m[0, 1] * v[0] + m[1, 1] * v[1] + m[2, 1] * v[2],
                     m[0, 2] * v[0] + m[1, 2] * v[1] + m[2, 2] * v[2]))
