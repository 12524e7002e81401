"""Sensor parameters and named profiles (SI units throughout).

White noise is given as a density (unit/√Hz); the per-sample standard deviation is
density·√(rate). Bias random walks are densities too (unit·√Hz, i.e. unit/√s).
"""

from __future__ import annotations

import math
from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from firmware_interface.geodesy import STANDARD_GRAVITY_M_S2

G = STANDARD_GRAVITY_M_S2
DEG = math.pi / 180.0


class _Config(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class ImuConfig(_Config):
    accel_noise_density: float = Field(0.0, ge=0, description="m/s^2/√Hz")
    accel_bias_turn_on: float = Field(0.0, ge=0, description="m/s^2, σ of the bias drawn at start")
    accel_bias_random_walk: float = Field(0.0, ge=0, description="m/s^2/√s")
    accel_range: float = Field(16 * G, gt=0, description="m/s^2 full scale")
    accel_lsb: float = Field(0.0, ge=0, description="m/s^2 per count (0 = no quantisation)")
    gyro_noise_density: float = Field(0.0, ge=0, description="rad/s/√Hz")
    gyro_bias_turn_on: float = Field(0.0, ge=0, description="rad/s")
    gyro_bias_random_walk: float = Field(0.0, ge=0, description="rad/s/√s")
    gyro_range: float = Field(2000 * DEG, gt=0, description="rad/s full scale")
    gyro_lsb: float = Field(0.0, ge=0, description="rad/s per count")


class MagConfig(_Config):
    rate_hz: float = Field(100.0, gt=0)
    noise_density: float = Field(0.0, ge=0, description="T/√Hz")
    bias_turn_on: float = Field(0.0, ge=0, description="T")
    declination_deg: float | None = Field(None, description="set all three to override the WMM field")
    inclination_deg: float | None = None
    intensity_t: float | None = Field(None, gt=0)
    epoch_year: float = Field(2026.0, description="decimal year for the World Magnetic Model")


class BaroConfig(_Config):
    rate_hz: float = Field(50.0, gt=0)
    noise_pa: float = Field(0.0, ge=0, description="Pa RMS per sample")
    drift_pa_per_s: float = Field(0.0, description="Pa/s steady drift")
    temperature_noise_degc: float = Field(0.0, ge=0)


class GpsConfig(_Config):
    rate_hz: float = Field(10.0, gt=0, le=20)
    delay_s: float = Field(0.0, ge=0, le=1.0, description="measurement to delivery")
    pos_white_noise_xy: float = Field(0.0, ge=0, description="m per sample")
    pos_white_noise_z: float = Field(0.0, ge=0)
    pos_markov_sigma_xy: float = Field(0.0, ge=0, description="m, steady-state σ of the slow error")
    pos_markov_sigma_z: float = Field(0.0, ge=0)
    pos_markov_tau_s: float = Field(60.0, gt=0)
    vel_noise: float = Field(0.0, ge=0, description="m/s per sample, per axis")
    eph_m: float = Field(0.5, gt=0, description="reported horizontal accuracy")
    epv_m: float = Field(0.8, gt=0, description="reported vertical accuracy")
    fix_type: int = Field(3, ge=0, le=6)
    satellites: int = Field(12, ge=0, le=60)


# Profiles. Sources: Gazebo Classic plugin defaults (docs/px4_protocol.md §15) for px4_sitl;
# datasheets for the paper's parts (InvenSense MPU-6000/6050 PS rev 3.4, u-blox NEO-M8N,
# TE MS5611-01BA03). Where a datasheet gives an uncalibrated figure that a flying PX4
# calibrates away, the profile uses a calibrated residual; docs/sensors.md lists each choice.
IMU_PROFILES: dict[str, ImuConfig] = {
    "ideal": ImuConfig(),
    "px4_sitl": ImuConfig(accel_noise_density=0.00637, gyro_noise_density=0.000873,
                          accel_lsb=G / 2048, gyro_lsb=2000 * DEG / 32768),
    "mpu6050": ImuConfig(accel_noise_density=400e-6 * G,  # 400 µg/√Hz
                         accel_bias_turn_on=0.05,  # residual after calibration (datasheet: ±50 mg raw)
                         accel_bias_random_walk=3e-4,
                         accel_lsb=G / 2048,  # ±16 g: 2048 LSB/g
                         gyro_noise_density=0.005 * DEG,  # 0.005 °/s/√Hz
                         gyro_bias_turn_on=0.1 * DEG,  # residual after the boot-time gyro calibration
                         gyro_bias_random_walk=2e-5,
                         gyro_lsb=DEG / 16.4),  # ±2000 °/s: 16.4 LSB/(°/s)
}
MAG_PROFILES: dict[str, MagConfig] = {
    "ideal": MagConfig(),
    "px4_sitl": MagConfig(rate_hz=100.0, noise_density=0.0004e-4),  # 0.0004 G/√Hz
}
BARO_PROFILES: dict[str, BaroConfig] = {
    "ideal": BaroConfig(),
    "px4_sitl": BaroConfig(rate_hz=50.0, noise_pa=1.0),
    "ms5611": BaroConfig(rate_hz=50.0, noise_pa=1.2, temperature_noise_degc=0.01),  # OSR 4096: 0.012 mbar
}
GPS_PROFILES: dict[str, GpsConfig] = {
    "ideal": GpsConfig(rate_hz=10.0, delay_s=0.0, eph_m=0.3, epv_m=0.4),
    "px4_sitl": GpsConfig(rate_hz=5.0, delay_s=0.12, pos_white_noise_xy=2e-4 * math.sqrt(5),
                          pos_white_noise_z=4e-4 * math.sqrt(5), pos_markov_sigma_xy=0.3,
                          pos_markov_sigma_z=0.6, pos_markov_tau_s=60.0, vel_noise=0.05,
                          eph_m=1.0, epv_m=1.0, satellites=10),
    # NEO-M8N: 2.5 m CEP (σ per axis = CEP / 1.1774), 0.05 m/s velocity accuracy, 10 Hz concurrent GNSS.
    "m8n": GpsConfig(rate_hz=10.0, delay_s=0.12, pos_white_noise_xy=0.3, pos_white_noise_z=0.5,
                     pos_markov_sigma_xy=2.5 / 1.1774, pos_markov_sigma_z=3.5, pos_markov_tau_s=120.0,
                     vel_noise=0.05, eph_m=2.5, epv_m=4.0, satellites=12),
}


def resolve(profiles: dict[str, Any], name: str, overrides: dict[str, Any] | None = None) -> Any:
    """A profile by name with field overrides, validated (unknown fields are refused)."""
    if name not in profiles:
        raise ValueError(f"unknown profile {name!r:.80}: expected one of {', '.join(sorted(profiles))}")
    base = profiles[name]
    return type(base).model_validate({**base.model_dump(), **(overrides or {})})
