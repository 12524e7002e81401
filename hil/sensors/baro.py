"""Barometer: ISA static pressure and temperature at the vehicle's altitude, with noise and drift."""

from __future__ import annotations

import numpy as np

from firmware_interface.hil_codec import Baro
from hil.sensors.config import BaroConfig
from hil.sensors.noise import NormalStream

P0_PA, T0_K, LAPSE_K_PER_M, ISA_EXPONENT = 101_325.0, 288.15, 0.0065, 5.25588
KELVIN = 273.15


def isa_pressure_pa(alt_msl_m: float) -> float:
    """Troposphere: p = p0·(1 − L·h/T0)^5.25588."""
    return P0_PA * (1.0 - LAPSE_K_PER_M * alt_msl_m / T0_K) ** ISA_EXPONENT


def isa_altitude_m(pressure_pa: float) -> float:
    return T0_K / LAPSE_K_PER_M * (1.0 - (pressure_pa / P0_PA) ** (1.0 / ISA_EXPONENT))


def isa_temperature_degc(alt_msl_m: float) -> float:
    return T0_K - LAPSE_K_PER_M * alt_msl_m - KELVIN


class Barometer:
    def __init__(self, config: BaroConfig, rng: np.random.Generator) -> None:
        self.config = config
        self._noise = NormalStream(rng, 2)

    def sample(self, t_s: float, alt_msl_m: float) -> Baro:
        n = self._noise.next()
        pressure = isa_pressure_pa(alt_msl_m) + self.config.drift_pa_per_s * t_s + self.config.noise_pa * n[0]
        temperature = isa_temperature_degc(alt_msl_m) + self.config.temperature_noise_degc * n[1]
        return Baro(pressure_pa=pressure, temperature_degc=temperature, pressure_alt_m=isa_altitude_m(pressure))
