"""SI / NED / FRD values ⇄ the fields of PX4's HIL messages.

The only place where MAVLink units exist (docs/px4_protocol.md §3–7): pressure in hPa,
magnetic field in gauss, lat/lon in degE7, altitude in mm, velocities in cm/s, course
in cdeg, eph/epv as accuracy in cm (what PX4 reads, whatever the XML says).
Functions return field dicts for `Link.send_fields` or read pymavlink messages.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

# HIL_SENSOR.fields_updated groups: PX4 ingests a group only if every bit of it is set.
ACCEL_BITS, GYRO_BITS, MAG_BITS = 0x007, 0x038, 0x1C0
BARO_BITS = 0x200 | 0x800 | 0x1000  # abs_pressure, pressure_alt, temperature
DIFF_PRESSURE_BITS = 0x400

MODE_FLAG_CUSTOM, MODE_FLAG_HIL, MODE_FLAG_ARMED = 1, 32, 128
ACTUATOR_FLAG_LOCKSTEP = 1

TESLA_PER_GAUSS = 1e-4
PA_PER_HPA = 100.0
UINT16_MAX, INT16_MAX = 65535, 32767

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


@dataclass(frozen=True, slots=True)
class ActuatorOutputs:
    """HIL_ACTUATOR_CONTROLS as the bench uses it."""

    t_us: int
    motors: tuple[float, float, float, float]  # PX4 quad X order, 0..1
    armed: bool
    lockstep: bool
    mode: int
    flags: int


def _clamp_int(value: float, low: int, high: int) -> int:
    return max(low, min(high, round(value)))


def hil_sensor_fields(r: SensorReadings) -> dict[str, Any]:
    accel = r.accel_frd or (0.0, 0.0, 0.0)
    gyro = r.gyro_frd or (0.0, 0.0, 0.0)
    mag_g = tuple(b / TESLA_PER_GAUSS for b in r.mag_frd_t) if r.mag_frd_t else (0.0, 0.0, 0.0)
    updated = 0
    updated |= ACCEL_BITS if r.accel_frd else 0
    updated |= GYRO_BITS if r.gyro_frd else 0
    updated |= MAG_BITS if r.mag_frd_t else 0
    updated |= BARO_BITS if r.baro else 0
    updated |= DIFF_PRESSURE_BITS if r.diff_pressure_pa is not None else 0
    baro = r.baro
    return {
        "time_usec": r.t_us,
        "xacc": accel[0], "yacc": accel[1], "zacc": accel[2],
        "xgyro": gyro[0], "ygyro": gyro[1], "zgyro": gyro[2],
        "xmag": mag_g[0], "ymag": mag_g[1], "zmag": mag_g[2],
        "abs_pressure": baro.pressure_pa / PA_PER_HPA if baro else 0.0,
        "diff_pressure": (r.diff_pressure_pa or 0.0) / PA_PER_HPA,
        "pressure_alt": baro.pressure_alt_m if baro else 0.0,
        "temperature": baro.temperature_degc if baro else 0.0,
        "fields_updated": updated,
        "id": r.sensor_id,
    }


def read_hil_sensor(msg: Any) -> SensorReadings:
    """The inverse of `hil_sensor_fields`: groups whose bits are incomplete are absent, as in PX4."""
    updated = msg.fields_updated

    def has(bits: int) -> bool:
        return updated & bits == bits

    return SensorReadings(
        t_us=msg.time_usec,
        accel_frd=(msg.xacc, msg.yacc, msg.zacc) if has(ACCEL_BITS) else None,
        gyro_frd=(msg.xgyro, msg.ygyro, msg.zgyro) if has(GYRO_BITS) else None,
        mag_frd_t=tuple(v * TESLA_PER_GAUSS for v in (msg.xmag, msg.ymag, msg.zmag)) if has(MAG_BITS) else None,
        baro=Baro(msg.abs_pressure * PA_PER_HPA, msg.temperature, msg.pressure_alt) if has(BARO_BITS) else None,
        diff_pressure_pa=msg.diff_pressure * PA_PER_HPA if has(DIFF_PRESSURE_BITS) else None,
        sensor_id=msg.id,
    )


def hil_gps_fields(g: GpsFix) -> dict[str, Any]:
    vn, ve, vd = g.vel_ned
    ground_speed = math.hypot(vn, ve)
    course_deg = math.degrees(math.atan2(ve, vn)) % 360.0
    return {
        "time_usec": g.t_us,
        "fix_type": g.fix_type,
        "lat": _clamp_int(g.lat_deg * 1e7, -900_000_000, 900_000_000),
        "lon": _clamp_int(g.lon_deg * 1e7, -1_800_000_000, 1_800_000_000),
        "alt": _clamp_int(g.alt_msl_m * 1000.0, -(2**31), 2**31 - 1),
        "eph": _clamp_int(g.eph_m * 100.0, 0, UINT16_MAX - 1),
        "epv": _clamp_int(g.epv_m * 100.0, 0, UINT16_MAX - 1),
        "vel": _clamp_int(ground_speed * 100.0, 0, UINT16_MAX - 1),
        "vn": _clamp_int(vn * 100.0, -INT16_MAX, INT16_MAX),
        "ve": _clamp_int(ve * 100.0, -INT16_MAX, INT16_MAX),
        "vd": _clamp_int(vd * 100.0, -INT16_MAX, INT16_MAX),
        "cog": _clamp_int(course_deg * 100.0, 0, 35999) if round(course_deg * 100) < 36000 else 0,
        "satellites_visible": g.satellites,
        "id": g.gps_id,
        "yaw": 0,  # PX4 ignores HIL_GPS.yaw
    }


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


def hil_state_quaternion_fields(s: GroundTruth) -> dict[str, Any]:
    # x/y/zacc: the XML says mG, but jMAVSim and Gazebo send m/s^2 x 1000 and PX4 SITL divides by 1000.
    return {
        "time_usec": s.t_us,
        "attitude_quaternion": list(s.q_wxyz),
        "rollspeed": s.rates_frd[0], "pitchspeed": s.rates_frd[1], "yawspeed": s.rates_frd[2],
        "lat": _clamp_int(s.lat_deg * 1e7, -900_000_000, 900_000_000),
        "lon": _clamp_int(s.lon_deg * 1e7, -1_800_000_000, 1_800_000_000),
        "alt": _clamp_int(s.alt_msl_m * 1000.0, -(2**31), 2**31 - 1),
        "vx": _clamp_int(s.vel_ned[0] * 100, -INT16_MAX, INT16_MAX),
        "vy": _clamp_int(s.vel_ned[1] * 100, -INT16_MAX, INT16_MAX),
        "vz": _clamp_int(s.vel_ned[2] * 100, -INT16_MAX, INT16_MAX),
        "ind_airspeed": _clamp_int(s.airspeed_m_s * 100, 0, UINT16_MAX),
        "true_airspeed": _clamp_int(s.airspeed_m_s * 100, 0, UINT16_MAX),
        "xacc": _clamp_int(s.specific_force_frd[0] * 1000, -INT16_MAX, INT16_MAX),
        "yacc": _clamp_int(s.specific_force_frd[1] * 1000, -INT16_MAX, INT16_MAX),
        "zacc": _clamp_int(s.specific_force_frd[2] * 1000, -INT16_MAX, INT16_MAX),
    }


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


MAV_FRAME_LOCAL_NED, MAV_FRAME_BODY_FRD = 1, 12
MAV_ESTIMATOR_TYPE_NAIVE = 1  # "this is the truth": no estimator made it


def odometry_fields(s: LocalTruth) -> dict[str, Any]:
    """ODOMETRY with pose and velocity in MAV_FRAME_LOCAL_NED (child_frame_id names the velocity's frame:
    NED, so no rotation rounds it), rates in body FRD; covariances unknown (NaN first element)."""
    nan_covariance = [math.nan] + [0.0] * 20
    return {"time_usec": s.t_us, "frame_id": MAV_FRAME_LOCAL_NED, "child_frame_id": MAV_FRAME_LOCAL_NED,
            "x": s.pos_ned[0], "y": s.pos_ned[1], "z": s.pos_ned[2], "q": list(s.q_wxyz),
            "vx": s.vel_ned[0], "vy": s.vel_ned[1], "vz": s.vel_ned[2],
            "rollspeed": s.rates_frd[0], "pitchspeed": s.rates_frd[1], "yawspeed": s.rates_frd[2],
            "pose_covariance": nan_covariance, "velocity_covariance": nan_covariance, "reset_counter": 0,
            "estimator_type": MAV_ESTIMATOR_TYPE_NAIVE, "quality": 100}


def read_odometry(msg: Any) -> LocalTruth:
    """The inverse of `odometry_fields` (velocity expected in MAV_FRAME_LOCAL_NED)."""
    return LocalTruth(t_us=msg.time_usec, pos_ned=(msg.x, msg.y, msg.z), vel_ned=(msg.vx, msg.vy, msg.vz),
                      q_wxyz=tuple(msg.q),
                      rates_frd=(msg.rollspeed, msg.pitchspeed, msg.yawspeed))


def hil_actuator_controls_fields(t_us: int, motors: tuple[float, ...], armed: bool, lockstep: bool,
                                 hil_enabled: bool = True) -> dict[str, Any]:
    """What a board sends: motors 0..1 in quad X order, all zero while disarmed."""
    controls = [float(m) if armed else 0.0 for m in motors] + [0.0] * (16 - len(motors))
    mode = MODE_FLAG_CUSTOM | (MODE_FLAG_ARMED if armed else 0) | (MODE_FLAG_HIL if hil_enabled else 0)
    return {"time_usec": t_us, "controls": controls, "mode": mode,
            "flags": ACTUATOR_FLAG_LOCKSTEP if lockstep else 0}


def read_actuator_controls(msg: Any, motor_count: int = 4, reversible: bool = False) -> ActuatorOutputs:
    """Motor commands clipped to PX4's ranges: 0..1 for motors, −1..1 for reversible ones."""
    low = -1.0 if reversible else 0.0
    motors = tuple(min(max(float(c), low), 1.0) if math.isfinite(c) else 0.0 for c in msg.controls[:motor_count])
    return ActuatorOutputs(
        t_us=msg.time_usec,
        motors=motors,  # type: ignore[arg-type]
        armed=bool(msg.mode & MODE_FLAG_ARMED),
        lockstep=bool(msg.flags & ACTUATOR_FLAG_LOCKSTEP),
        mode=msg.mode,
        flags=msg.flags,
    )
