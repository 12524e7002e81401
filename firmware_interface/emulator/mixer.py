"""Mixer: collective thrust and body torques to the commands of n rotors, in PX4's motor order.

The rotors are the nominal vehicle's (`NominalVehicle.rotors`: the bench sends the plant's); their thrusts
come from the pseudo-inverse of the effectiveness matrix (thrust, roll, pitch and yaw torque per newton of
each rotor), the exact inverse for four. Commands follow through the emulator's nominal thrust curve
T = T_max((1−k)u + k u²). When the rotors cannot deliver everything, roll/pitch come before yaw, and near
full thrust before collective (collective is lowered to keep them). At low thrust collective is never raised
above the demand, as in PX4 without airmode: raising it would make the vehicle climb whenever a large
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
QUAD_X_TOLERANCE_M = 1e-9


@shared_maths
def rotor_thrusts(inverse: np.ndarray, t_max: float, reversible: bool, thrust_n: float,
                  torque_frd: np.ndarray) -> np.ndarray:
    """Rotor thrusts (N) for a collective thrust and body torques, `inverse` the inverted effectiveness matrix."""
    low = -t_max if reversible else 0.0  # reversible (ideal) rotors push both ways
    rp = inverse[:, 1] * torque_frd[0] + inverse[:, 2] * torque_frd[1]
    collective = min(max(thrust_n / inverse.shape[0], low), t_max)
    room_low = (collective - low) / -rp.min() if rp.min() < -1e-12 else np.inf
    spread = rp.max() - rp.min()
    scale = min(1.0, room_low, (t_max - low) / spread if spread > 0 else np.inf)
    rp *= scale  # what does not fit above the lowest thrust is cut, not bought with extra collective
    collective = min(collective, t_max - rp.max())  # near full thrust: lower collective
    base = collective + rp
    yaw = inverse[:, 3] * torque_frd[2]
    share = 1.0
    for rotor in range(inverse.shape[0]):  # the largest share of the yaw torque that still fits
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


def effectiveness(vehicle: NominalVehicle) -> np.ndarray:
    """(T, τx, τy, τz) per newton of each rotor's thrust along −z: τ = r × (0, 0, −T) = (−y T, x T, 0), and
    the rotor's drag torque ±k_m T (a CCW rotor yaws the body clockwise: +z in FRD).

    A quad X at the nominal arm length (to 1 nm: what a layout written from azimuths gives) is built from
    its closed form, ±arm/√2, so that its flights stay bit for bit what they were before the mixer took a
    layout (cos 45° differs from 1/√2 in the last bit)."""
    positions = np.array([r.position_frd_m for r in vehicle.rotors])
    spin = np.array([1.0 if r.spin == "ccw" else -1.0 for r in vehicle.rotors])
    a = vehicle.arm_length / math.sqrt(2.0)
    if len(spin) == 4 and np.all(spin == _SPIN) and np.allclose(positions[:, :2], np.column_stack((a * _X, a * _Y)),
                                                                  rtol=0.0, atol=QUAD_X_TOLERANCE_M):
        positions = np.column_stack((a * _X, a * _Y))
    return np.vstack((np.ones(len(spin)), -positions[:, 1], positions[:, 0], vehicle.yaw_moment_coeff * spin))


class Mixer:
    def __init__(self, vehicle: NominalVehicle) -> None:
        effect = effectiveness(vehicle)
        square = effect.shape[0] == effect.shape[1]
        self._inverse = np.linalg.inv(effect) if square else np.linalg.pinv(effect)  # rotor thrusts from (T, τ)
        self.rotor_count = effect.shape[1]
        self.t_max = vehicle.thrust_max
        self.k = vehicle.thrust_curve_k
        self.reversible = vehicle.reversible

    def rotor_thrusts(self, thrust_n: float, torque_frd: np.ndarray) -> np.ndarray:
        return rotor_thrusts(self._inverse, self.t_max, self.reversible, thrust_n, np.asarray(torque_frd, np.float64))

    def commands(self, thrust_n: float, torque_frd: np.ndarray) -> np.ndarray:
        """Rotor commands 0..1 through the inverse thrust curve."""
        return rotor_commands(self._inverse, self.t_max, self.k, self.reversible, thrust_n,
                              np.asarray(torque_frd, np.float64))
