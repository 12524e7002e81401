"""All sensors of one vehicle, driven by one seeded generator, producing HIL packets."""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationInfo, field_validator

from firmware_interface.hil_codec import Baro, GpsFix, SensorReadings, readings_of_row, sensor_row
from firmware_interface.hil_frames import (
    HAS_ACCEL,
    HAS_BARO,
    HAS_GYRO,
    HAS_MAG,
    ROW_ACCEL,
    ROW_BARO,
    ROW_MAG_T,
    ROW_PRESENT,
    ROW_SIZE,
    ROW_T_US,
)
from hil.sensors.baro import Barometer, baro_sample, isa_altitude_m
from hil.sensors.config import (
    BARO_PROFILES,
    GPS_PROFILES,
    IMU_PROFILES,
    MAG_PROFILES,
    resolve,
)
from hil.sensors.faults import FaultInjector, SensorFault
from hil.sensors.geodesy import Home
from hil.sensors.gps import Gps, gps_step
from hil.sensors.imu import Imu, imu_sample
from hil.sensors.mag import Magnetometer, mag_sample
from hil.sensors.noise import BLOCK, SENSORS
from hil.sensors.truth import TrueState


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


@SENSORS.inline
def due(schedule: np.ndarray, t_us: int) -> bool:
    """A fixed-rate trigger on the bench clock: schedule = (next µs, or -1 before the first; period µs)."""
    if schedule[0] < 0:
        schedule[0] = t_us
    if t_us < schedule[0]:
        return False
    schedule[0] += schedule[1]
    return True


@SENSORS.inline
def suite_sense(imu: np.ndarray, imu_noise: np.ndarray, imu_cursor: np.ndarray, mag: np.ndarray,
                mag_noise: np.ndarray, mag_cursor: np.ndarray, mag_due: np.ndarray, baro: np.ndarray,
                baro_noise: np.ndarray, baro_cursor: np.ndarray, baro_due: np.ndarray, home_alt_m: float,
                gps: np.ndarray, gps_state: np.ndarray, gps_line: np.ndarray, gps_noise: np.ndarray,
                gps_cursor: np.ndarray, frame: np.ndarray, t_us: int, pos_ned: np.ndarray, vel_ned: np.ndarray,
                q_wxyz: np.ndarray, rates_frd: np.ndarray, specific_force_frd: np.ndarray, row: np.ndarray) -> None:
    """Every sensor of the suite for the bench step at `t_us`, in the order each draws its noise, into the step's
    row (`hil_frames.ROW_*`): the IMU every step; mag, baro and GPS when due (the arguments: the suite's arrays,
    `SensorSuite.buffers`, then the true state)."""
    row[:] = 0.0
    row[ROW_T_US] = t_us
    present = HAS_ACCEL | HAS_GYRO
    imu_sample(imu, imu_noise, imu_cursor, specific_force_frd, rates_frd, row[ROW_ACCEL:ROW_ACCEL + 6])
    if due(mag_due, t_us):
        mag_sample(mag, mag_noise, mag_cursor, q_wxyz, row[ROW_MAG_T:ROW_MAG_T + 3])
        present |= HAS_MAG
    if due(baro_due, t_us):
        baro_sample(baro, baro_noise, baro_cursor, t_us * 1e-6, home_alt_m - pos_ned[2], row[ROW_BARO:ROW_BARO + 3])
        present |= HAS_BARO
    row[ROW_PRESENT] = present
    gps_step(gps, gps_state, gps_line, gps_noise, gps_cursor, frame, t_us, pos_ned, vel_ned, row)


@SENSORS.inline
def _vector(buffer: np.ndarray, layout: np.ndarray, k: int) -> np.ndarray:
    """`suite_sense`'s k-th array, a vector, as a view of `buffer` (`SensorSuite.buffers`)."""
    return buffer[layout[3 * k]:layout[3 * k] + layout[3 * k + 1]]


@SENSORS.inline
def _table(buffer: np.ndarray, layout: np.ndarray, k: int) -> np.ndarray:
    """`suite_sense`'s k-th array, a table of rows, as a view of `buffer`."""
    at, rows, columns = layout[3 * k], layout[3 * k + 1], layout[3 * k + 2]
    return buffer[at:at + rows * columns].reshape((rows, columns))


NOISE_CURSORS = (2, 5, 9, 16)  # which of `suite_sense`'s arrays are the noise blocks' cursors
REFILL_DUE = 3 * 18  # in the int buffer, after the layout of the 18 arrays: 1 once a noise block's last row is taken


@SENSORS.inline
def sense_buffers(floats: np.ndarray, ints: np.ndarray, t_us: int, pos_ned: np.ndarray, vel_ned: np.ndarray,
                  q_wxyz: np.ndarray, rates_frd: np.ndarray, specific_force_frd: np.ndarray, row: np.ndarray) -> None:
    """`suite_sense` on the suite's arrays as they lie in its two buffers (the layout heads `ints`)."""
    suite_sense(_vector(floats, ints, 0), _table(floats, ints, 1), _vector(ints, ints, 2), _vector(floats, ints, 3),
                _table(floats, ints, 4), _vector(ints, ints, 5), _vector(ints, ints, 6), _vector(floats, ints, 7),
                _table(floats, ints, 8), _vector(ints, ints, 9), _vector(ints, ints, 10), _vector(floats, ints, 11)[0],
                _vector(floats, ints, 12), _vector(ints, ints, 13), _table(floats, ints, 14), _table(floats, ints, 15),
                _vector(ints, ints, 16), _vector(floats, ints, 17), t_us, pos_ned, vel_ned, q_wxyz, rates_frd,
                specific_force_frd, row)
    used_up = 0
    for k in NOISE_CURSORS:
        used_up |= _vector(ints, ints, k)[0] == BLOCK
    ints[REFILL_DUE] = used_up


@SENSORS.compiled
def _sense(floats: np.ndarray, ints: np.ndarray, t_us: int, pos_ned: np.ndarray, vel_ned: np.ndarray,
           q_wxyz: np.ndarray, rates_frd: np.ndarray, specific_force_frd: np.ndarray, row: np.ndarray) -> None:
    sense_buffers(floats, ints, t_us, pos_ned, vel_ned, q_wxyz, rates_frd, specific_force_frd, row)


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
        self._mag_due = np.array((-1, round(1e6 / mag_config.rate_hz)), dtype=np.int64)
        self._baro_due = np.array((-1, round(1e6 / baro_config.rate_hz)), dtype=np.int64)
        fault_rngs = fault_rng.spawn(5)
        self._faults = {
            name: FaultInjector([f for f in config.faults if f.sensor == name], r)
            for name, r in zip(("accel", "gyro", "mag", "baro", "gps"), fault_rngs, strict=True)
        }
        self.has_faults = bool(config.faults)
        self.row = np.zeros(ROW_SIZE)  # the latest step's readings
        self._home_alt_m = np.array((float(home.alt_msl_m),))
        self.buffers = self._into_buffers()

    def _into_buffers(self) -> tuple[np.ndarray, np.ndarray]:
        """What `suite_sense` takes before the true state (every sensor's parameters, noise and schedule, in its
        order) moved into one float and one int buffer, each holder keeping a view of its part; the layout, (offset,
        rows, columns) of each (0 columns: a vector), heads the int buffer. Compiled code then takes two arguments:
        numba unboxes each array of a tuple at every call (~1.2 µs a step for 18, on the path from the board's reply
        to the next write)."""
        imu, mag, baro, gps = self.imu, self.mag, self.baro, self.gps
        holders = ((imu, "params"), (imu.noise, "rows"), (imu.noise, "cursor"), (mag, "params"), (mag.noise, "rows"),
                   (mag.noise, "cursor"), (self, "_mag_due"), (baro, "params"), (baro.noise, "rows"),
                   (baro.noise, "cursor"), (self, "_baro_due"), (self, "_home_alt_m"), (gps, "params"), (gps, "state"),
                   (gps, "line"), (gps.noise, "rows"), (gps.noise, "cursor"), (gps, "frame"))
        arrays = [getattr(holder, name) for holder, name in holders]
        is_int = [array.dtype == np.int64 for array in arrays]
        ends = {True: REFILL_DUE + 1, False: 0}  # the ints' layout and the refill flag first
        layout = []
        for array, integer in zip(arrays, is_int, strict=True):
            layout += [ends[integer], array.shape[0], array.shape[1] if array.ndim == 2 else 0]
            ends[integer] += array.size
        floats, ints = np.zeros(ends[False]), np.zeros(ends[True], dtype=np.int64)
        ints[:len(layout)] = layout
        ints[REFILL_DUE] = 1  # no block drawn yet
        for (holder, name), array, integer, at in zip(holders, arrays, is_int, layout[::3], strict=True):
            view = (ints if integer else floats)[at:at + array.size].reshape(array.shape)
            view[...] = array
            setattr(holder, name, view)
        return floats, ints

    def refill(self) -> None:
        """Each sensor's next block of noise once it has taken the last row of the one before (when the compiled
        models say one has: `REFILL_DUE`; four checks in Python cost ~0.7 µs a step on the bench's critical path)."""
        ints = self.buffers[1]
        if ints[REFILL_DUE]:
            for sensor in (self.imu, self.mag, self.baro, self.gps):
                sensor.noise.refill()
            ints[REFILL_DUE] = 0

    def step(self, truth: TrueState, fault_time_s: float | None = None) -> tuple[SensorReadings, GpsFix | None]:
        """Sensor outputs for this bench step; faults are timed by `fault_time_s` (default: bench time)."""
        self.refill()
        pos, vel, q, rates, force = (np.asarray(v, dtype=np.float64) for v in (
            truth.pos_ned, truth.vel_ned, truth.q_wxyz, truth.rates_frd, truth.specific_force_frd))
        _sense(*self.buffers, truth.t_us, pos, vel, q, rates, force, self.row)
        if self.has_faults:
            self.apply_faults(truth.t_us * 1e-6 if fault_time_s is None else fault_time_s)
        return readings_of_row(self.row)

    def apply_faults(self, t_s: float) -> None:
        """The sensor faults active at `t_s` on the step's row, in this order: the injectors may share one random
        stream."""
        readings, gps = readings_of_row(self.row)
        f = self._faults
        accel = None if readings.accel_frd is None else f["accel"].apply(t_s, readings.accel_frd)
        gyro = None if readings.gyro_frd is None else f["gyro"].apply(t_s, readings.gyro_frd)
        mag = None if readings.mag_frd_t is None else f["mag"].apply(t_s, readings.mag_frd_t)
        baro = readings.baro
        if baro is not None:
            p = f["baro"].apply(t_s, (baro.pressure_pa,))
            baro = None if p is None else Baro(p[0], baro.temperature_degc, isa_altitude_m(p[0]))
        if gps is not None and f["gps"].apply(t_s, (0.0,)) is None:  # a GPS fault can only drop fixes
            gps = None
        self.row[:] = sensor_row(SensorReadings(readings.t_us, accel, gyro, mag, baro), gps)
