"""The frames a simulator sends a board, packed from SI / NED / FRD values by compiled code: HIL_SENSOR, HIL_GPS,
SET_POSITION_TARGET_LOCAL_NED, ODOMETRY and HIL_STATE_QUATERNION. The only place where their MAVLink units exist
(docs/px4_protocol.md §3–7): pressure in hPa, magnetic field in gauss, lat/lon in degE7, altitude in mm,
velocities in cm/s, course in cdeg, eph/epv as accuracy in cm (what PX4 reads, whatever the XML says).

A step's sensor values travel as one float64 row (`ROW_*`): what the sensor models write and these packers read,
so that the bench's compiled step goes from the plant's outputs to the bytes of a write without a Python object
in between. `firmware_interface.hil_codec` turns rows into `SensorReadings` and `GpsFix` and back, and reads
what a board sends.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from pymavlink.dialects.v20 import common
from pymavlink.dialects.v20.common import MAV_ESTIMATOR_TYPE_NAIVE, MAV_FRAME_LOCAL_NED

from firmware_interface.compiled_code import CompiledCode
from firmware_interface.link import frame_packing
from firmware_interface.link.frame_packing import (
    PAYLOAD,
    finish_frame,
    get_f32,
    get_u32,
    get_u64,
    message_layout,
    payload_of,
    put_f32,
    put_u8,
    put_u16,
    put_u32,
    put_u64,
)

inline = CompiledCode.inline


# Positions in a step's sensor row (module constants: compiled code reads them as numbers). ROW_PRESENT holds
# which groups the step has (the HAS_* bits); ROW_BARO: pressure Pa, temperature degC, pressure altitude m; the fix
# delivered this step from ROW_GPS_T_US, the time it was measured, to ROW_SATELLITES.
ROW_T_US, ROW_ACCEL, ROW_GYRO, ROW_MAG_T, ROW_BARO, ROW_PRESENT = 0, 1, 4, 7, 10, 13
ROW_GPS_T_US, ROW_LAT_DEG, ROW_LON_DEG, ROW_ALT_MSL_M, ROW_GPS_VEL_NED = 14, 15, 16, 17, 18
ROW_EPH_M, ROW_EPV_M, ROW_FIX_TYPE, ROW_SATELLITES = 21, 22, 23, 24
ROW_SIZE = 25


HAS_ACCEL, HAS_GYRO, HAS_MAG, HAS_BARO, HAS_GPS = 1, 2, 4, 8, 16
# HIL_SENSOR.fields_updated groups: PX4 ingests a group only if every bit of it is set.
ACCEL_BITS, GYRO_BITS, MAG_BITS = 0x007, 0x038, 0x1C0
BARO_BITS = 0x200 | 0x800 | 0x1000  # abs_pressure, pressure_alt, temperature
DIFF_PRESSURE_BITS = 0x400
TESLA_PER_GAUSS = 1e-4
PA_PER_HPA = 100.0
UINT16_MAX, INT16_MAX, INT32_MAX = 65535, 32767, 2**31 - 1
SETPOINT_IGNORE_YAW_RATE = common.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE  # position, velocity, acc. and yaw used



HIL_SENSOR, HIL_GPS = message_layout(common.MAVLink_hil_sensor_message), message_layout(common.MAVLink_hil_gps_message)
SETPOINT = message_layout(common.MAVLink_set_position_target_local_ned_message)
ODOMETRY, HIL_STATE_QUATERNION = message_layout(common.MAVLink_odometry_message), message_layout(
    common.MAVLink_hil_state_quaternion_message)
RAD_TO_DEG = 180.0 / math.pi  # as math.degrees multiplies


@inline
def clamp_round(value: float, low: int, high: int) -> int:
    """The nearest integer (ties to even, as Python's round) within [low, high]."""
    return max(low, min(high, int(np.rint(value))))


@inline
def put_hil_sensor(buf: np.ndarray, at: int, seq: int, system_id: int, component_id: int, row: np.ndarray) -> int:
    """HIL_SENSOR of the row's IMU, magnetometer and barometer groups (a group it lacks is zeros and out of
    fields_updated); returns where the frame ends."""
    p, present = at + PAYLOAD, int(row[ROW_PRESENT])
    put_u64(buf, p, int(row[ROW_T_US]))
    updated = 0
    for group, first, bits, scale in ((HAS_ACCEL, ROW_ACCEL, ACCEL_BITS, 1.0), (HAS_GYRO, ROW_GYRO, GYRO_BITS, 1.0),
                                      (HAS_MAG, ROW_MAG_T, MAG_BITS, TESLA_PER_GAUSS)):
        for k in range(3):
            put_f32(buf, p + 8 + 4 * (first - 1 + k), row[first + k] / scale if present & group else 0.0)
        updated |= bits if present & group else 0
    baro = present & HAS_BARO
    put_f32(buf, p + 44, row[ROW_BARO] / PA_PER_HPA if baro else 0.0)  # abs_pressure, hPa
    put_f32(buf, p + 48, 0.0)  # diff_pressure: no airspeed sensor
    put_f32(buf, p + 52, row[ROW_BARO + 2] if baro else 0.0)  # pressure_alt, m
    put_f32(buf, p + 56, row[ROW_BARO + 1] if baro else 0.0)  # temperature, degC
    put_u32(buf, p + 60, updated | (BARO_BITS if baro else 0))
    put_u8(buf, p + 64, 0)  # id
    return finish_frame(buf, at, HIL_SENSOR[2], seq, system_id, component_id, HIL_SENSOR[0], HIL_SENSOR[1])


@inline
def hil_sensor_row(frame: bytes, payload: np.ndarray, row: np.ndarray) -> None:
    """A HIL_SENSOR frame into the step row it was packed from, as PX4 reads it: a group is present only when
    every bit of it is in fields_updated (otherwise zeros in the row); the magnetometer in tesla, the pressure in
    Pa. `payload`: room for the payload (HIL_SENSOR[2] bytes). The inverse of `put_hil_sensor` but for float32's
    rounding; the values are those of pymavlink's decode, unit for unit (tests/test_emulator_sensor_frame.py)."""
    payload_of(frame, payload)
    updated = get_u32(payload, 60)
    row[ROW_T_US] = get_u64(payload, 0)
    present = 0
    for group, first, bits, scale in ((HAS_ACCEL, ROW_ACCEL, ACCEL_BITS, 1.0), (HAS_GYRO, ROW_GYRO, GYRO_BITS, 1.0),
                                      (HAS_MAG, ROW_MAG_T, MAG_BITS, TESLA_PER_GAUSS)):
        whole = updated & bits == bits
        for k in range(3):
            row[first + k] = get_f32(payload, 8 + 4 * (first - 1 + k)) * scale if whole else 0.0
        present |= group if whole else 0
    baro = updated & BARO_BITS == BARO_BITS
    row[ROW_BARO] = get_f32(payload, 44) * PA_PER_HPA if baro else 0.0
    row[ROW_BARO + 1] = get_f32(payload, 56) if baro else 0.0
    row[ROW_BARO + 2] = get_f32(payload, 52) if baro else 0.0
    row[ROW_PRESENT] = present | (HAS_BARO if baro else 0)


@inline
def put_hil_gps(buf: np.ndarray, at: int, seq: int, system_id: int, component_id: int, row: np.ndarray) -> int:
    """HIL_GPS of the row's fix. The ground speed is libm's hypot, within an ulp of Python's math.hypot: it only
    rounds to HIL_GPS.vel (cm/s), which neither PX4's estimator nor the emulator reads."""
    p = at + PAYLOAD
    vn, ve, vd = row[ROW_GPS_VEL_NED], row[ROW_GPS_VEL_NED + 1], row[ROW_GPS_VEL_NED + 2]
    course_deg = math.atan2(ve, vn) * RAD_TO_DEG % 360.0
    put_u64(buf, p, int(row[ROW_GPS_T_US]))
    put_u32(buf, p + 8, clamp_round(row[ROW_LAT_DEG] * 1e7, -900_000_000, 900_000_000))
    put_u32(buf, p + 12, clamp_round(row[ROW_LON_DEG] * 1e7, -1_800_000_000, 1_800_000_000))
    put_u32(buf, p + 16, clamp_round(row[ROW_ALT_MSL_M] * 1000.0, -INT32_MAX - 1, INT32_MAX))
    put_u16(buf, p + 20, clamp_round(row[ROW_EPH_M] * 100.0, 0, UINT16_MAX - 1))
    put_u16(buf, p + 22, clamp_round(row[ROW_EPV_M] * 100.0, 0, UINT16_MAX - 1))
    put_u16(buf, p + 24, clamp_round(math.hypot(vn, ve) * 100.0, 0, UINT16_MAX - 1))
    for k, v in enumerate((vn, ve, vd)):
        put_u16(buf, p + 26 + 2 * k, clamp_round(v * 100.0, -INT16_MAX, INT16_MAX))
    put_u16(buf, p + 32, clamp_round(course_deg * 100.0, 0, 35999) if np.rint(course_deg * 100) < 36000 else 0)
    put_u8(buf, p + 34, int(row[ROW_FIX_TYPE]))
    put_u8(buf, p + 35, int(row[ROW_SATELLITES]))
    put_u8(buf, p + 36, 0)  # id
    put_u16(buf, p + 37, 0)  # yaw: PX4 ignores HIL_GPS.yaw
    return finish_frame(buf, at, HIL_GPS[2], seq, system_id, component_id, HIL_GPS[0], HIL_GPS[1])


@inline
def put_setpoint(buf: np.ndarray, at: int, seq: int, system_id: int, component_id: int, t_boot_ms: int,
                 target: tuple[int, int], pos_ned: np.ndarray, vel_ned: np.ndarray, acc_ned: np.ndarray,
                 yaw_rad: float) -> int:
    """SET_POSITION_TARGET_LOCAL_NED for `target` (system, component): position, velocity, acceleration and yaw
    in MAV_FRAME_LOCAL_NED, the yaw rate ignored."""
    p = at + PAYLOAD
    put_u32(buf, p, t_boot_ms)
    for k in range(3):
        put_f32(buf, p + 4 + 4 * k, pos_ned[k])
        put_f32(buf, p + 16 + 4 * k, vel_ned[k])
        put_f32(buf, p + 28 + 4 * k, acc_ned[k])
    put_f32(buf, p + 40, yaw_rad)
    put_f32(buf, p + 44, 0.0)  # yaw_rate
    put_u16(buf, p + 48, SETPOINT_IGNORE_YAW_RATE)
    put_u8(buf, p + 50, target[0])
    put_u8(buf, p + 51, target[1])
    put_u8(buf, p + 52, MAV_FRAME_LOCAL_NED)
    return finish_frame(buf, at, SETPOINT[2], seq, system_id, component_id, SETPOINT[0], SETPOINT[1])


@inline
def put_odometry(buf: np.ndarray, at: int, seq: int, system_id: int, component_id: int, t_us: int,
                 pos_ned: np.ndarray, vel_ned: np.ndarray, q_wxyz: np.ndarray, rates_frd: np.ndarray) -> int:
    """ODOMETRY of the true state: pose and velocity in MAV_FRAME_LOCAL_NED (child_frame_id names the velocity's
    frame: NED, so no rotation rounds it), rates in body FRD, float32 on the wire; covariances unknown (NaN
    first elements)."""
    p = at + PAYLOAD
    put_u64(buf, p, t_us)
    for k in range(3):
        put_f32(buf, p + 8 + 4 * k, pos_ned[k])
        put_f32(buf, p + 36 + 4 * k, vel_ned[k])
        put_f32(buf, p + 48 + 4 * k, rates_frd[k])
    for k in range(4):
        put_f32(buf, p + 20 + 4 * k, q_wxyz[k])
    for k in range(42):  # pose_covariance[21], velocity_covariance[21]
        put_f32(buf, p + 60 + 4 * k, np.nan if k % 21 == 0 else 0.0)
    for k, value in enumerate((MAV_FRAME_LOCAL_NED, MAV_FRAME_LOCAL_NED, 0, MAV_ESTIMATOR_TYPE_NAIVE, 100)):
        put_u8(buf, p + 228 + k, value)  # frame_id, child_frame_id, reset_counter, estimator_type, quality
    return finish_frame(buf, at, ODOMETRY[2], seq, system_id, component_id, ODOMETRY[0], ODOMETRY[1])


@inline
def odometry_row(frame: bytes, payload: np.ndarray, row: np.ndarray) -> None:
    """An ODOMETRY frame as `put_odometry` packs it, into `row`: position, velocity (NED), attitude quaternion
    (w, x, y, z) and body rates (FRD), each float32 value as it came. `payload`: room for ODOMETRY[2] bytes."""
    payload_of(frame, payload)
    for k in range(3):
        row[k] = get_f32(payload, 8 + 4 * k)
        row[3 + k] = get_f32(payload, 36 + 4 * k)
        row[10 + k] = get_f32(payload, 48 + 4 * k)
    for k in range(4):
        row[6 + k] = get_f32(payload, 20 + 4 * k)


@inline
def put_hil_state_quaternion(buf: np.ndarray, at: int, seq: int, system_id: int, component_id: int, t_us: int,
                             q_wxyz: np.ndarray, rates_frd: np.ndarray, geodetic: np.ndarray, vel_ned: np.ndarray,
                             specific_force_frd: np.ndarray, airspeed_m_s: float) -> int:
    """HIL_STATE_QUATERNION of the true state (`geodetic`: lat deg, lon deg, altitude m). x/y/zacc: the XML says
    mG, but jMAVSim and Gazebo send m/s² × 1000 and PX4 SITL divides by 1000."""
    p = at + PAYLOAD
    put_u64(buf, p, t_us)
    for k in range(4):
        put_f32(buf, p + 8 + 4 * k, q_wxyz[k])
    for k in range(3):
        put_f32(buf, p + 24 + 4 * k, rates_frd[k])
        put_u16(buf, p + 48 + 2 * k, clamp_round(vel_ned[k] * 100, -INT16_MAX, INT16_MAX))
        put_u16(buf, p + 58 + 2 * k, clamp_round(specific_force_frd[k] * 1000, -INT16_MAX, INT16_MAX))
    put_u32(buf, p + 36, clamp_round(geodetic[0] * 1e7, -900_000_000, 900_000_000))
    put_u32(buf, p + 40, clamp_round(geodetic[1] * 1e7, -1_800_000_000, 1_800_000_000))
    put_u32(buf, p + 44, clamp_round(geodetic[2] * 1000.0, -INT32_MAX - 1, INT32_MAX))
    put_u16(buf, p + 54, clamp_round(airspeed_m_s * 100, 0, UINT16_MAX))  # ind_airspeed
    put_u16(buf, p + 56, clamp_round(airspeed_m_s * 100, 0, UINT16_MAX))  # true_airspeed
    return finish_frame(buf, at, HIL_STATE_QUATERNION[2], seq, system_id, component_id, HIL_STATE_QUATERNION[0],
                        HIL_STATE_QUATERNION[1])


# --- entry points for Python callers: each packs one frame at the start of `buf` and returns its length ----------

FRAMES = CompiledCode("hil-frames", (Path(__file__), Path(frame_packing.__file__)))


@FRAMES.compiled
def encode_hil_sensor(buf: np.ndarray, seq: int, system_id: int, component_id: int, row: np.ndarray) -> int:
    return put_hil_sensor(buf, 0, seq, system_id, component_id, row)


@FRAMES.compiled
def encode_hil_gps(buf: np.ndarray, seq: int, system_id: int, component_id: int, row: np.ndarray) -> int:
    return put_hil_gps(buf, 0, seq, system_id, component_id, row)


@FRAMES.compiled
def encode_setpoint(buf: np.ndarray, seq: int, system_id: int, component_id: int, t_boot_ms: int,
                    target_system: int, target_component: int, pos_ned: np.ndarray, vel_ned: np.ndarray,
                    acc_ned: np.ndarray, yaw_rad: float) -> int:
    return put_setpoint(buf, 0, seq, system_id, component_id, t_boot_ms, (target_system, target_component), pos_ned,
                        vel_ned, acc_ned, yaw_rad)


@FRAMES.compiled
def encode_odometry(buf: np.ndarray, seq: int, system_id: int, component_id: int, t_us: int, pos_ned: np.ndarray,
                    vel_ned: np.ndarray, q_wxyz: np.ndarray, rates_frd: np.ndarray) -> int:
    return put_odometry(buf, 0, seq, system_id, component_id, t_us, pos_ned, vel_ned, q_wxyz, rates_frd)


@FRAMES.compiled
def encode_hil_state_quaternion(buf: np.ndarray, seq: int, system_id: int, component_id: int, t_us: int,
                                q_wxyz: np.ndarray, rates_frd: np.ndarray, geodetic: np.ndarray, vel_ned: np.ndarray,
                                specific_force_frd: np.ndarray, airspeed_m_s: float) -> int:
    return put_hil_state_quaternion(buf, 0, seq, system_id, component_id, t_us, q_wxyz, rates_frd, geodetic, vel_ned,
                                    specific_force_frd, airspeed_m_s)
