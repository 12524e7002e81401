"""Barometer: ISA static pressure and temperature at the vehicle's altitude, with noise and drift."""

from __future__ import annotations

import numpy as np

from firmware_interface.hil_codec import Baro
from hil.sensors.config import BaroConfig
from hil.sensors.noise import SENSORS, NormalStream

P0_PA, T0_K, LAPSE_K_PER_M, ISA_EXPONENT = 101_325.0, 288.15, 0.0065, 5.25588
KELVIN = 273.15


@SENSORS.inline
def isa_pressure_pa(alt_msl_m: float) -> float:
    """Troposphere: p = p0·(1 − L·h/T0)^5.25588."""
    return P0_PA * (1.0 - LAPSE_K_PER_M * alt_msl_m / T0_K) ** ISA_EXPONENT


@SENSORS.inline
def isa_altitude_m(pressure_pa: float) -> float:
    return T0_K / LAPSE_K_PER_M * (1.0 - (pressure_pa / P0_PA) ** (1.0 / ISA_EXPONENT))


@SENSORS.inline
def isa_temperature_degc(alt_msl_m: float) -> float:
    return T0_K - LAPSE_K_PER_M * alt_msl_m - KELVIN


@SENSORS.inline
def baro_sample(baro: np.ndarray, noise: np.ndarray, cursor: np.ndarray, t_s: float, alt_msl_m: float,
                out: np.ndarray) -> None:
    """Pressure (Pa, with drift baro[0] Pa/s and noise σ baro[1]), temperature (degC, noise σ baro[2]) and the
    pressure altitude of that pressure into out[0:3]."""
    n = noise[cursor[0]]
    cursor[0] += 1
    pressure = isa_pressure_pa(alt_msl_m) + baro[0] * t_s + baro[1] * n[0]
    out[0] = pressure
    out[1] = isa_temperature_degc(alt_msl_m) + baro[2] * n[1]
    out[2] = isa_altitude_m(pressure)


@SENSORS.compiled
def _sample(baro: np.ndarray, noise: np.ndarray, cursor: np.ndarray, t_s: float, alt_msl_m: float,
            out: np.ndarray) -> None:
    baro_sample(baro, noise, cursor, t_s, alt_msl_m, out)


class Barometer:
    def __init__(self, config: BaroConfig, rng: np.random.Generator) -> None:
        self.config = config
        self.params = np.array((config.drift_pa_per_s, config.noise_pa, config.temperature_noise_degc))
        self.noise = NormalStream(rng, 2)
        self._out = np.empty(3)

    def sample(self, t_s: float, alt_msl_m: float) -> Baro:
        self.noise.refill()
        _sample(self.params, self.noise.rows, self.noise.cursor, float(t_s), float(alt_msl_m), self._out)
        pressure, temperature, altitude = self._out.tolist()
        return Baro(pressure_pa=pressure, temperature_degc=temperature, pressure_alt_m=altitude)
