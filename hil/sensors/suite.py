"""All sensors of one vehicle, driven by one seeded generator, producing HIL packets."""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationInfo, field_validator

from firmware_interface.hil_codec import Baro, GpsFix, SensorReadings
from hil.sensors.baro import Barometer, isa_altitude_m
from hil.sensors.config import (
    BARO_PROFILES,
    GPS_PROFILES,
    IMU_PROFILES,
    MAG_PROFILES,
    resolve,
)
from hil.sensors.faults import FaultInjector, SensorFault
from hil.sensors.geodesy import Home
from hil.sensors.gps import Gps
from hil.sensors.imu import Imu
from hil.sensors.mag import Magnetometer
from hil.sensors.truth import TrueState

Vec3 = tuple[float, float, float]


class SensorChoice(BaseModel):
    """`{profile: NAME, FIELD: VALUE, ...}`: a named profile with overrides of any field."""

    model_config = ConfigDict(extra="allow", frozen=True)
    profile: str = "px4_sitl"

    @property
    def overrides(self) -> dict[str, Any]:
        return dict(self.model_extra or {})


PROFILES: dict[str, dict[str, Any]] = {"imu": IMU_PROFILES, "mag": MAG_PROFILES, "baro": BARO_PROFILES,
                                       "gps": GPS_PROFILES}


class SensorsConfig(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)
    imu: SensorChoice = SensorChoice()
    mag: SensorChoice = SensorChoice()
    baro: SensorChoice = SensorChoice()
    gps: SensorChoice = SensorChoice()
    faults: list[SensorFault] = Field(default_factory=list)

    @field_validator("imu", "mag", "baro", "gps")
    @classmethod
    def _resolves(cls, choice: SensorChoice, info: ValidationInfo) -> SensorChoice:
        """The profile exists and its overrides are valid fields and values: found when the scenario loads,
        not when the suite is built at the start of a run (errors keep their field: sensors.gps.rate_hz)."""
        resolve(PROFILES[str(info.field_name)], choice.profile, choice.overrides)
        return choice


class _Schedule:
    """A fixed-rate trigger on the bench clock."""

    def __init__(self, rate_hz: float) -> None:
        self.period_us = round(1e6 / rate_hz)
        self._next_us: int | None = None

    def due(self, t_us: int) -> bool:
        if self._next_us is None:
            self._next_us = t_us
        if t_us < self._next_us:
            return False
        self._next_us += self.period_us
        return True


class SensorSuite:
    """IMU every bench step; mag, baro and GPS at their own rates; faults applied last."""

    def __init__(self, config: SensorsConfig, home: Home, bench_rate_hz: float, rng: np.random.Generator) -> None:
        imu_rng, mag_rng, baro_rng, gps_rng, fault_rng = rng.spawn(5)  # independent streams per sensor
        self.home = home
        self.imu = Imu(resolve(IMU_PROFILES, config.imu.profile, config.imu.overrides), bench_rate_hz, imu_rng)
        mag_config = resolve(MAG_PROFILES, config.mag.profile, config.mag.overrides)
        baro_config = resolve(BARO_PROFILES, config.baro.profile, config.baro.overrides)
        self.mag = Magnetometer(mag_config, home, mag_rng)
        self.baro = Barometer(baro_config, baro_rng)
        self.gps = Gps(resolve(GPS_PROFILES, config.gps.profile, config.gps.overrides), home, gps_rng)
        self._mag_due, self._baro_due = _Schedule(mag_config.rate_hz), _Schedule(baro_config.rate_hz)
        fault_rngs = fault_rng.spawn(5)
        self._faults = {
            name: FaultInjector([f for f in config.faults if f.sensor == name], r)
            for name, r in zip(("accel", "gyro", "mag", "baro", "gps"), fault_rngs, strict=True)
        }
        self._has_faults = bool(config.faults)

    def step(self, truth: TrueState, fault_time_s: float | None = None) -> tuple[SensorReadings, GpsFix | None]:
        """Sensor outputs for this bench step; faults are timed by `fault_time_s` (default: bench time)."""
        t_us = truth.t_us
        accel, gyro = self.imu.sample(truth.specific_force_frd, truth.rates_frd)
        mag = self.mag.sample(truth.q_wxyz) if self._mag_due.due(t_us) else None
        baro = self.baro.sample(t_us * 1e-6, self.home.alt_msl_m - float(truth.pos_ned[2])) \
            if self._baro_due.due(t_us) else None
        gps = self.gps.step(t_us, truth.pos_ned, truth.vel_ned)
        if self._has_faults:
            when = t_us * 1e-6 if fault_time_s is None else fault_time_s
            faulted_accel, faulted_gyro, mag, baro, gps = self._apply_faults(when, accel, gyro, mag, baro, gps)
            return SensorReadings(t_us=t_us, accel_frd=faulted_accel, gyro_frd=faulted_gyro, mag_frd_t=mag,
                                  baro=baro), gps
        return SensorReadings(t_us=t_us, accel_frd=accel, gyro_frd=gyro, mag_frd_t=mag, baro=baro), gps

    def _apply_faults(self, t_s: float, accel: Vec3, gyro: Vec3, mag: Vec3 | None, baro: Baro | None,
                      gps: GpsFix | None) -> tuple[Vec3 | None, Vec3 | None, Vec3 | None, Baro | None, GpsFix | None]:
        f = self._faults  # in this order: the injectors may share one random stream
        faulted_accel, faulted_gyro = f["accel"].apply(t_s, accel), f["gyro"].apply(t_s, gyro)
        faulted_mag = None if mag is None else f["mag"].apply(t_s, mag)
        if baro is not None:
            p = f["baro"].apply(t_s, (baro.pressure_pa,))
            baro = None if p is None else Baro(p[0], baro.temperature_degc, isa_altitude_m(p[0]))
        if gps is not None and f["gps"].apply(t_s, (0.0,)) is None:  # a GPS fault can only drop fixes
            gps = None
        return faulted_accel, faulted_gyro, faulted_mag, baro, gps
