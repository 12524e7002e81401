"""Mixer: collective thrust and body torques to four rotor commands, quad X (PX4 order).

Through the emulator's nominal thrust curve T = T_max((1−k)u + k u²). When the rotors
cannot deliver everything, roll/pitch come before yaw, and near full thrust before collective
(collective is lowered to keep them). At low thrust collective is never raised above the
demand, as in PX4 without airmode: raising it would make the vehicle climb whenever a large
attitude correction saturates the rotors, and the altitude loop would lose control.
"""

from __future__ import annotations

import math

import numpy as np

from firmware_interface.emulator.compiled import flight_code, shared_maths
from firmware_interface.emulator.config import NominalVehicle

# rotor (x, y) signs in FRD and spin (+1 CCW), PX4 quad X: 1 FR, 2 RL, 3 FL, 4 RR
_X = np.array((1.0, -1.0, 1.0, -1.0))
_Y = np.array((1.0, -1.0, -1.0, 1.0))
_SPIN = np.array((1.0, 1.0, -1.0, -1.0))


@shared_maths
def rotor_thrusts(inverse: np.ndarray, t_max: float, reversible: bool, thrust_n: float,
                  torque_frd: np.ndarray) -> np.ndarray:
    """Rotor thrusts (N) for a collective thrust and body torques, `inverse` the inverted effectiveness matrix."""
    low = -t_max if reversible else 0.0  # reversible (ideal) rotors push both ways
    rp = inverse[:, 1] * torque_frd[0] + inverse[:, 2] * torque_frd[1]
    collective = min(max(thrust_n / 4.0, low), t_max)
    room_low = (collective - low) / -rp.min() if rp.min() < -1e-12 else np.inf
    spread = rp.max() - rp.min()
    scale = min(1.0, room_low, (t_max - low) / spread if spread > 0 else np.inf)
    rp *= scale  # what does not fit above the lowest thrust is cut, not bought with extra collective
    collective = min(collective, t_max - rp.max())  # near full thrust: lower collective
    base = collective + rp
    yaw = inverse[:, 3] * torque_frd[2]
    share = 1.0
    for rotor in range(4):  # the largest share of the yaw torque that still fits
        if yaw[rotor] > 0:
            share = min(share, (t_max - base[rotor]) / yaw[rotor])
        elif yaw[rotor] < 0:
            share = min(share, (low - base[rotor]) / yaw[rotor])
    return np.clip(base + max(share, 0.0) * yaw, low, t_max)


@flight_code
def rotor_commands(inverse: np.ndarray, t_max: float, k: float, reversible: bool, thrust_n: float,
                   torque_frd: np.ndarray) -> np.ndarray:
    """Rotor commands 0..1 (−1..1 reversible) through the inverse of the thrust curve."""
    ratio = rotor_thrusts(inverse, t_max, reversible, thrust_n, torque_frd) / t_max
    if k == 0:
        return ratio
    magnitude = np.abs(ratio)
    return np.sign(ratio) * (-(1 - k) + np.sqrt((1 - k) ** 2 + 4 * k * magnitude)) / (2 * k)


class Mixer:
    def __init__(self, vehicle: NominalVehicle) -> None:
        a = vehicle.arm_length / math.sqrt(2.0)
        effect = np.vstack((np.ones(4), -a * _Y, a * _X, vehicle.yaw_moment_coeff * _SPIN))
        self._inverse = np.linalg.inv(effect)  # rotor thrusts from (T, τx, τy, τz)
        self.t_max = vehicle.thrust_max
        self.k = vehicle.thrust_curve_k
        self.reversible = vehicle.reversible

    def rotor_thrusts(self, thrust_n: float, torque_frd: np.ndarray) -> np.ndarray:
        return rotor_thrusts(self._inverse, self.t_max, self.reversible, thrust_n, np.asarray(torque_frd, np.float64))

    def commands(self, thrust_n: float, torque_frd: np.ndarray) -> np.ndarray:
        """Rotor commands 0..1 through the inverse thrust curve."""
        return rotor_commands(self._inverse, self.t_max, self.k, self.reversible, thrust_n,
                              np.asarray(torque_frd, np.float64))
