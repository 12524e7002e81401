"""Magnetometer: the earth field at home (World Magnetic Model, or stated) in body FRD, tesla."""

from __future__ import annotations

import math

import numpy as np
from pygeomag import GeoMag

from hil.sensors.config import MagConfig
from hil.sensors.geodesy import Home
from hil.sensors.noise import NormalStream
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


class Magnetometer:
    def __init__(self, config: MagConfig, home: Home, rng: np.random.Generator) -> None:
        self.field_ned = earth_field_ned(config, home)
        self.bias = (config.bias_turn_on * rng.standard_normal(3)).tolist()
        self._sigma = config.noise_density * math.sqrt(config.rate_hz)
        self._noise = NormalStream(rng, 3)

    def sample(self, q_wxyz: np.ndarray) -> tuple[float, float, float]:
        """Field in body FRD, tesla."""
        b = rotate_ned_to_frd(q_wxyz, self.field_ned)
        n, s, bias = self._noise.next(), self._sigma, self.bias
        return (b[0] + bias[0] + s * n[0], b[1] + bias[1] + s * n[1], b[2] + bias[2] + s * n[2])
