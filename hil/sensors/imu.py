"""Accelerometer and gyroscope: white noise, turn-on bias, bias random walk, range, quantisation."""

from __future__ import annotations

import math

import numpy as np

from hil.sensors.config import ImuConfig
from hil.sensors.noise import NormalStream

Vec3 = tuple[float, float, float]


class Imu:
    """Samples at the bench rate: accel (specific force, m/s^2) and gyro (rad/s), both FRD."""

    def __init__(self, config: ImuConfig, rate_hz: float, rng: np.random.Generator) -> None:
        c = config
        dt = 1.0 / rate_hz
        self._sigma = [c.accel_noise_density * math.sqrt(rate_hz)] * 3 + [c.gyro_noise_density * math.sqrt(rate_hz)] * 3
        self._walk = [c.accel_bias_random_walk * math.sqrt(dt)] * 3 + [c.gyro_bias_random_walk * math.sqrt(dt)] * 3
        turn_on = rng.standard_normal(6).tolist()
        self.bias = [c.accel_bias_turn_on * b for b in turn_on[:3]] + [c.gyro_bias_turn_on * b for b in turn_on[3:]]
        self._range = [c.accel_range] * 3 + [c.gyro_range] * 3
        self._lsb = [c.accel_lsb] * 3 + [c.gyro_lsb] * 3
        self._noise = NormalStream(rng, 12)

    def sample(self, specific_force_frd: np.ndarray, rates_frd: np.ndarray) -> tuple[Vec3, Vec3]:
        n = self._noise.next()
        truth = specific_force_frd.tolist() + rates_frd.tolist()
        bias, sigma, walk, limit, lsb = self.bias, self._sigma, self._walk, self._range, self._lsb
        out = [t + b + s * w for t, b, s, w in zip(truth, bias, sigma, n[:6], strict=True)]
        self.bias = [b + k * w for b, k, w in zip(bias, walk, n[6:], strict=True)]
        out = [min(max(v, -r), r) for v, r in zip(out, limit, strict=True)]
        out = [round(v / q) * q if q > 0 else v for v, q in zip(out, lsb, strict=True)]
        return (out[0], out[1], out[2]), (out[3], out[4], out[5])
