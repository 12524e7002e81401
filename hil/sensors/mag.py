"""Magnetometer: the earth field at home (World Magnetic Model, or stated) in body FRD, tesla."""

from __future__ import annotations

import math

import numpy as np
from pygeomag import GeoMag

from hil.sensors.config import MagConfig
from hil.sensors.geodesy import Home
from hil.sensors.noise import SENSORS, NormalStream
from hil.sensors.truth import rotate_ned_to_frd

NANOTESLA = 1e-9


def earth_field_ned(config: MagConfig, home: Home) -> np.ndarray:
    """Field vector in NED, tesla: from declination/inclination/intensity if all are given, else WMM."""
    dec_deg, inc_deg, total = config.declination_deg, config.inclination_deg, config.intensity_t
    if dec_deg is not None and inc_deg is not None and total is not None:
        dec, inc = math.radians(dec_deg), math.radians(inc_deg)
        horizontal = total * math.cos(inc)
        return np.array((horizontal * math.cos(dec), horizontal * math.sin(dec), total * math.sin(inc)))
    if any(v is not None for v in (dec_deg, inc_deg, total)):
        raise ValueError("mag: give declination_deg, inclination_deg and intensity_t together, or none")
    result = GeoMag().calculate(glat=home.lat_deg, glon=home.lon_deg, alt=home.alt_msl_m / 1000.0,
                                time=config.epoch_year, allow_date_outside_lifespan=True)
    return np.array((result.x, result.y, result.z)) * NANOTESLA


@SENSORS.inline
def mag_sample(mag: np.ndarray, noise: np.ndarray, cursor: np.ndarray, q_wxyz: np.ndarray, out: np.ndarray) -> None:
    """The field (mag[0:3], NED, tesla) in body FRD plus the bias (mag[3:6]) and white noise (σ mag[6]) into
    out[0:3]."""
    b = rotate_ned_to_frd(q_wxyz, mag[0:3])
    n = noise[cursor[0]]
    cursor[0] += 1
    for k in range(3):
        out[k] = b[k] + mag[3 + k] + mag[6] * n[k]


@SENSORS.compiled
def _sample(mag: np.ndarray, noise: np.ndarray, cursor: np.ndarray, q_wxyz: np.ndarray, out: np.ndarray) -> None:
    mag_sample(mag, noise, cursor, q_wxyz, out)


class Magnetometer:
    def __init__(self, config: MagConfig, home: Home, rng: np.random.Generator) -> None:
        self.field_ned = earth_field_ned(config, home)
        bias = config.bias_turn_on * rng.standard_normal(3)
        self.params = np.array([*self.field_ned, *bias, config.noise_density * math.sqrt(config.rate_hz)])
        self.noise = NormalStream(rng, 3)
        self._out = np.empty(3)

    @property
    def bias(self) -> list[float]:
        return self.params[3:6].tolist()

    def sample(self, q_wxyz: np.ndarray) -> tuple[float, float, float]:
        """Field in body FRD, tesla."""
        self.noise.refill()
        _sample(self.params, self.noise.rows, self.noise.cursor, np.asarray(q_wxyz, dtype=np.float64), self._out)
        x, y, z = self._out.tolist()
        return x, y, z
