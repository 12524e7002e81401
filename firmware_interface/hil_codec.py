"""SI / NED / FRD values ⇄ PX4's HIL messages, as Python objects: a step's sensor values (`SensorReadings`, a
`GpsFix`) to and from the float64 row `firmware_interface.hil_frames` packs into frames, and the HIL messages read
from pymavlink messages (MAVLink units to SI here: docs/px4_protocol.md §3–7). A board's actuator reply is read
from its bytes by `firmware_interface.actuator_reply`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from firmware_interface.hil_frames import (
    HAS_ACCEL,
    HAS_BARO,
    HAS_GPS,
    HAS_GYRO,
    HAS_MAG,
    ROW_ACCEL,
    ROW_ALT_MSL_M,
    ROW_BARO,
    ROW_EPH_M,
    ROW_EPV_M,
    ROW_FIX_TYPE,
    ROW_GPS_T_US,
    ROW_GPS_VEL_NED,
    ROW_GYRO,
    ROW_LAT_DEG,
    ROW_LON_DEG,
    ROW_MAG_T,
    ROW_PRESENT,
    ROW_SATELLITES,
    ROW_SIZE,
    ROW_T_US,
)

MODE_FLAG_CUSTOM, MODE_FLAG_HIL, MODE_FLAG_ARMED = 1, 32, 128
ACTUATOR_FLAG_LOCKSTEP = 1

Vec3 = tuple[float, float, float]


@dataclass(frozen=True, slots=True)
class Baro:
    pressure_pa: float
    temperature_degc: float
    pressure_alt_m: float


@dataclass(frozen=True, slots=True)
class SensorReadings:
    """One HIL_SENSOR sample; None leaves that group out (and out of fields_updated)."""

    t_us: int
    accel_frd: Vec3 | None = None  # specific force, m/s^2: (0, 0, -9.81) at rest
    gyro_frd: Vec3 | None = None  # rad/s
    mag_frd_t: Vec3 | None = None  # tesla
    baro: Baro | None = None
    diff_pressure_pa: float | None = None
    sensor_id: int = 0


@dataclass(frozen=True, slots=True)
class GpsFix:
    t_us: int
    lat_deg: float
    lon_deg: float
    alt_msl_m: float
    vel_ned: Vec3  # m/s
    eph_m: float  # horizontal accuracy
    epv_m: float  # vertical accuracy
    fix_type: int = 3
    satellites: int = 10
    gps_id: int = 0


@dataclass(frozen=True, slots=True)
class GroundTruth:
    """The true state, for HIL_STATE_QUATERNION (PX4 SITL and the emulator only, never a real board)."""

    t_us: int
    q_wxyz: tuple[float, float, float, float]  # body FRD -> NED
    rates_frd: Vec3
    lat_deg: float
    lon_deg: float
    alt_msl_m: float
    vel_ned: Vec3
    specific_force_frd: Vec3
    airspeed_m_s: float = 0.0


@dataclass(frozen=True, slots=True)
class LocalTruth:
    """The true state in the bench's local NED frame, for ODOMETRY: float32 on the wire (~1e-7 relative),
    where HIL_STATE_QUATERNION's integer lat/lon, mm and cm/s quantise what a controller differentiates.
    The emulator's exact-state path only; PX4 SITL keeps HIL_STATE_QUATERNION."""

    t_us: int
    pos_ned: Vec3  # m, about the bench's home
    vel_ned: Vec3  # m/s
    q_wxyz: tuple[float, float, float, float]  # body FRD -> NED
    rates_frd: Vec3  # rad/s


class ActuatorOutputs(NamedTuple):
    """HIL_ACTUATOR_CONTROLS as the bench uses it (a tuple: made every lockstep step, at a third of a frozen
    dataclass's cost)."""

    t_us: int
    motors: tuple[float, float, float, float]  # PX4 quad X order, 0..1
    armed: bool
    lockstep: bool
    mode: int
    flags: int


def sensor_row(readings: SensorReadings, gps: GpsFix | None = None) -> np.ndarray:
    """The step's row (`hil_frames.ROW_*`) of these readings and fix."""
    row = np.zeros(ROW_SIZE)
    row[ROW_T_US] = readings.t_us
    present = 0
    for group, first, values in ((HAS_ACCEL, ROW_ACCEL, readings.accel_frd), (HAS_GYRO, ROW_GYRO, readings.gyro_frd),
                                 (HAS_MAG, ROW_MAG_T, readings.mag_frd_t)):
        if values is not None:
            row[first:first + 3] = values
            present |= group
    if readings.baro is not None:
        b = readings.baro
        row[ROW_BARO:ROW_BARO + 3] = (b.pressure_pa, b.temperature_degc, b.pressure_alt_m)
        present |= HAS_BARO
    if gps is not None:
        row[ROW_GPS_T_US:ROW_ALT_MSL_M + 1] = (gps.t_us, gps.lat_deg, gps.lon_deg, gps.alt_msl_m)
        row[ROW_GPS_VEL_NED:ROW_GPS_VEL_NED + 3] = gps.vel_ned
        row[ROW_EPH_M:ROW_SATELLITES + 1] = (gps.eph_m, gps.epv_m, gps.fix_type, gps.satellites)
        present |= HAS_GPS
    row[ROW_PRESENT] = present
    return row


def readings_of_row(row: np.ndarray) -> tuple[SensorReadings, GpsFix | None]:
    """The inverse of `sensor_row`: the step's readings and, if it has one, the fix delivered."""
    values = row.tolist()
    present = int(values[ROW_PRESENT])

    def group(bit: int, first: int) -> Vec3 | None:
        return (values[first], values[first + 1], values[first + 2]) if present & bit else None

    baro = Baro(values[ROW_BARO], values[ROW_BARO + 1], values[ROW_BARO + 2]) if present & HAS_BARO else None
    readings = SensorReadings(int(values[ROW_T_US]), group(HAS_ACCEL, ROW_ACCEL), group(HAS_GYRO, ROW_GYRO),
                              group(HAS_MAG, ROW_MAG_T), baro)
    if not present & HAS_GPS:
        return readings, None
    gps = GpsFix(int(values[ROW_GPS_T_US]), values[ROW_LAT_DEG], values[ROW_LON_DEG], values[ROW_ALT_MSL_M],
                 group(HAS_GPS, ROW_GPS_VEL_NED) or (0.0, 0.0, 0.0), values[ROW_EPH_M], values[ROW_EPV_M],
                 int(values[ROW_FIX_TYPE]), int(values[ROW_SATELLITES]))
    return readings, gps


def read_hil_gps(msg: Any) -> GpsFix:
    return GpsFix(
        t_us=msg.time_usec,
        lat_deg=msg.lat * 1e-7,
        lon_deg=msg.lon * 1e-7,
        alt_msl_m=msg.alt * 1e-3,
        vel_ned=(msg.vn * 0.01, msg.ve * 0.01, msg.vd * 0.01),
        eph_m=msg.eph * 0.01,
        epv_m=msg.epv * 0.01,
        fix_type=msg.fix_type,
        satellites=msg.satellites_visible,
        gps_id=msg.id,
    )


def read_hil_state_quaternion(msg: Any) -> GroundTruth:
    return GroundTruth(
        t_us=msg.time_usec,
        q_wxyz=tuple(msg.attitude_quaternion),
        rates_frd=(msg.rollspeed, msg.pitchspeed, msg.yawspeed),
        lat_deg=msg.lat * 1e-7,
        lon_deg=msg.lon * 1e-7,
        alt_msl_m=msg.alt * 1e-3,
        vel_ned=(msg.vx * 0.01, msg.vy * 0.01, msg.vz * 0.01),
        specific_force_frd=(msg.xacc * 1e-3, msg.yacc * 1e-3, msg.zacc * 1e-3),
        airspeed_m_s=msg.true_airspeed * 0.01,
    )


def hil_actuator_controls_fields(t_us: int, motors: tuple[float, ...], armed: bool, lockstep: bool,
                                 hil_enabled: bool = True) -> dict[str, Any]:
    """What a board sends: motors 0..1 in quad X order, all zero while disarmed."""
    controls = [float(m) if armed else 0.0 for m in motors] + [0.0] * (16 - len(motors))
    mode = MODE_FLAG_CUSTOM | (MODE_FLAG_ARMED if armed else 0) | (MODE_FLAG_HIL if hil_enabled else 0)
    return {"time_usec": t_us, "controls": controls, "mode": mode,
            "flags": ACTUATOR_FLAG_LOCKSTEP if lockstep else 0}
