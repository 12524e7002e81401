"""The plant's true state as the sensors see it (SI, NED / FRD)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hil.sensors.noise import SENSORS


@dataclass(frozen=True, slots=True)
class TrueState:
    t_us: int
    pos_ned: np.ndarray  # m, about home
    vel_ned: np.ndarray  # m/s
    q_wxyz: np.ndarray  # body FRD -> NED
    rates_frd: np.ndarray  # rad/s
    specific_force_frd: np.ndarray  # m/s^2, (0, 0, -g) at rest


@SENSORS.inline
def rotate_ned_to_frd(q_wxyz: np.ndarray, v_ned: np.ndarray) -> tuple[float, float, float]:
    """Rᵀ·v for the body→NED rotation of unit quaternion q."""
    w, x, y, z = q_wxyz[0], q_wxyz[1], q_wxyz[2], q_wxyz[3]
    vx, vy, vz = v_ned[0], v_ned[1], v_ned[2]
    r00, r01, r02 = 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)
    r10, r11, r12 = 2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)
    r20, r21, r22 = 2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)
    return (r00 * vx + r10 * vy + r20 * vz, r01 * vx + r11 * vy + r21 * vz, r02 * vx + r12 * vy + r22 * vz)
