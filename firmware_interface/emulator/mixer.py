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

from firmware_interface.emulator.config import NominalVehicle

# rotor (x, y) signs in FRD and spin (+1 CCW), PX4 quad X: 1 FR, 2 RL, 3 FL, 4 RR
_X = np.array((1.0, -1.0, 1.0, -1.0))
_Y = np.array((1.0, -1.0, -1.0, 1.0))
_SPIN = np.array((1.0, 1.0, -1.0, -1.0))


class Mixer:
    def __init__(self, vehicle: NominalVehicle) -> None:
        a = vehicle.arm_length / math.sqrt(2.0)
        effect = np.vstack((np.ones(4), -a * _Y, a * _X, vehicle.yaw_moment_coeff * _SPIN))
        self._inverse = np.linalg.inv(effect)  # rotor thrusts from (T, τx, τy, τz)
        self.t_max = vehicle.thrust_max
        self.k = vehicle.thrust_curve_k
        self.reversible = vehicle.reversible

    def rotor_thrusts(self, thrust_n: float, torque_frd: np.ndarray) -> np.ndarray:
        inv, t_max = self._inverse, self.t_max
        low = -t_max if self.reversible else 0.0  # reversible (ideal) rotors push both ways
        rp = inv[:, 1] * torque_frd[0] + inv[:, 2] * torque_frd[1]
        collective = min(max(thrust_n / 4.0, low), t_max)
        room_low = (collective - low) / -float(rp.min()) if rp.min() < -1e-12 else np.inf
        spread = float(rp.max() - rp.min())
        scale = min(1.0, room_low, (t_max - low) / spread if spread > 0 else np.inf)
        rp *= scale  # what does not fit above the lowest thrust is cut, not bought with extra collective
        collective = min(collective, t_max - float(rp.max()))  # near full thrust: lower collective
        base = collective + rp
        yaw = inv[:, 3] * torque_frd[2]
        share = 1.0
        for b, y in zip(base, yaw, strict=True):  # the largest share of the yaw torque that still fits
            if y > 0:
                share = min(share, (t_max - b) / y)
            elif y < 0:
                share = min(share, (low - b) / y)
        return np.clip(base + max(share, 0.0) * yaw, low, t_max)

    def commands(self, thrust_n: float, torque_frd: np.ndarray) -> np.ndarray:
        """Rotor commands 0..1 through the inverse thrust curve."""
        ratio = self.rotor_thrusts(thrust_n, torque_frd) / self.t_max
        if self.k == 0:
            return ratio
        k, magnitude = self.k, np.abs(ratio)
        return np.sign(ratio) * (-(1 - k) + np.sqrt((1 - k) ** 2 + 4 * k * magnitude)) / (2 * k)
