"""Accelerometer and gyroscope: white noise, turn-on bias, bias random walk, range, quantisation."""

from __future__ import annotations

import math

import numpy as np

from hil.sensors.config import ImuConfig
from hil.sensors.noise import SENSORS, NormalStream

Vec3 = tuple[float, float, float]
# positions in an IMU's parameter array, each 6 wide (accel x, y, z, gyro x, y, z); the bias changes as it walks
BIAS, SIGMA, WALK, RANGE, LSB = 0, 6, 12, 18, 24


@SENSORS.inline
def imu_sample(imu: np.ndarray, noise: np.ndarray, cursor: np.ndarray, specific_force_frd: np.ndarray,
               rates_frd: np.ndarray, out: np.ndarray) -> None:
    """accel (specific force, m/s^2) and gyro (rad/s), FRD, into out[0:6]; the bias walks a step."""
    n = noise[cursor[0]]
    cursor[0] += 1
    for k in range(6):
        truth = specific_force_frd[k] if k < 3 else rates_frd[k - 3]
        bias = imu[BIAS + k]
        value = truth + bias + imu[SIGMA + k] * n[k]
        imu[BIAS + k] = bias + imu[WALK + k] * n[6 + k]
        limit = imu[RANGE + k]
        value = min(max(value, -limit), limit)
        lsb = imu[LSB + k]
        # Python's round: half to even, and to an integer (so a count of 0 is +0.0, never -0.0)
        out[k] = int(np.rint(value / lsb)) * lsb if lsb > 0 else value


@SENSORS.compiled
def _sample(imu: np.ndarray, noise: np.ndarray, cursor: np.ndarray, specific_force_frd: np.ndarray,
            rates_frd: np.ndarray, out: np.ndarray) -> None:
    imu_sample(imu, noise, cursor, specific_force_frd, rates_frd, out)


class Imu:
    """Samples at the bench rate: accel (specific force, m/s^2) and gyro (rad/s), both FRD."""

    def __init__(self, config: ImuConfig, rate_hz: float, rng: np.random.Generator) -> None:
        c = config
        dt = 1.0 / rate_hz
        turn_on = rng.standard_normal(6).tolist()
        self.params = np.array(
            [c.accel_bias_turn_on * b for b in turn_on[:3]] + [c.gyro_bias_turn_on * b for b in turn_on[3:]]
            + [c.accel_noise_density * math.sqrt(rate_hz)] * 3 + [c.gyro_noise_density * math.sqrt(rate_hz)] * 3
            + [c.accel_bias_random_walk * math.sqrt(dt)] * 3 + [c.gyro_bias_random_walk * math.sqrt(dt)] * 3
            + [c.accel_range] * 3 + [c.gyro_range] * 3 + [c.accel_lsb] * 3 + [c.gyro_lsb] * 3)
        self.noise = NormalStream(rng, 12)
        self._out = np.empty(6)

    @property
    def bias(self) -> list[float]:
        return self.params[BIAS:BIAS + 6].tolist()

    def sample(self, specific_force_frd: np.ndarray, rates_frd: np.ndarray) -> tuple[Vec3, Vec3]:
        self.noise.refill()
        _sample(self.params, self.noise.rows, self.noise.cursor, np.asarray(specific_force_frd, dtype=np.float64),
                np.asarray(rates_frd, dtype=np.float64), self._out)
        out = self._out.tolist()
        return (out[0], out[1], out[2]), (out[3], out[4], out[5])
