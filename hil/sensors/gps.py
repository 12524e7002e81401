"""GPS receiver: rate, Gauss-Markov plus white position error, velocity noise, a delay line."""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from firmware_interface.hil_codec import GpsFix
from hil.sensors.config import GpsConfig
from hil.sensors.geodesy import Home, ned_to_geodetic
from hil.sensors.noise import NormalStream


class Gps:
    """Measures every 1/rate s; each fix is delivered `delay_s` after it was measured."""

    def __init__(self, config: GpsConfig, home: Home, rng: np.random.Generator) -> None:
        self.config = config
        self.home = home
        self.period_us = round(1e6 / config.rate_hz)
        self.delay_us = round(config.delay_s * 1e6)
        c = config
        self._white = np.array((c.pos_white_noise_xy, c.pos_white_noise_xy, c.pos_white_noise_z))
        sigma = np.array((c.pos_markov_sigma_xy, c.pos_markov_sigma_xy, c.pos_markov_sigma_z))
        phi = math.exp(-1.0 / (c.rate_hz * c.pos_markov_tau_s))
        self._phi = phi
        self._drive = sigma * math.sqrt(1.0 - phi * phi)  # keeps the steady-state σ at `sigma`
        self.markov = sigma * rng.standard_normal(3)  # start in steady state
        self._noise = NormalStream(rng, 9)
        self._next_us: int | None = None
        self._pending: deque[tuple[int, GpsFix]] = deque()

    def step(self, t_us: int, pos_ned: np.ndarray, vel_ned: np.ndarray) -> GpsFix | None:
        """Call every bench step; returns the fix delivered at this step, if any."""
        if self._next_us is None:
            self._next_us = t_us
        if t_us >= self._next_us:
            self._pending.append((t_us + self.delay_us, self._measure(t_us, pos_ned, vel_ned)))
            self._next_us += self.period_us
        delivered = None
        while self._pending and self._pending[0][0] <= t_us:
            delivered = self._pending.popleft()[1]
        return delivered

    def _measure(self, t_us: int, pos_ned: np.ndarray, vel_ned: np.ndarray) -> GpsFix:
        n = np.array(self._noise.next())
        self.markov = self._phi * self.markov + self._drive * n[:3]
        pos = pos_ned + self.markov + self._white * n[3:6]
        vel = vel_ned + self.config.vel_noise * n[6:9]
        lat, lon, alt = ned_to_geodetic(float(pos[0]), float(pos[1]), float(pos[2]), self.home)
        return GpsFix(t_us=t_us, lat_deg=lat, lon_deg=lon, alt_msl_m=alt,
                      vel_ned=(float(vel[0]), float(vel[1]), float(vel[2])),
                      eph_m=self.config.eph_m, epv_m=self.config.epv_m,
                      fix_type=self.config.fix_type, satellites=self.config.satellites)
