"""The emulator's HIL_SENSOR step from the frame's bytes (`hil_frames.hil_sensor_row`, `Estimator.on_sensor_frame`)
against pymavlink's decode of the same frames, as PX4 reads the groups of fields_updated."""

from __future__ import annotations

import numpy as np
import pytest
from pymavlink.dialects.v20 import common

from firmware_interface import hil_codec as codec
from firmware_interface import hil_frames
from firmware_interface.emulator.config import EstimatorSettings
from firmware_interface.emulator.estimator import Estimator
from firmware_interface.hil_codec import GpsFix

ALL_GROUPS = 0x1BFF  # accel 0x7 | gyro 0x38 | mag 0x1C0 | baro 0x1A00 (abs_pressure, pressure_alt, temperature)


def sensor_message(t_us: int, updated: int, accel=(0.12, -0.34, -9.79), gyro=(0.011, -0.022, 0.033),
                   mag_gauss=(0.21, 0.01, 0.43), baro=(955.4, 488.25, 11.8),
                   sensor_id: int = 0) -> common.MAVLink_hil_sensor_message:
    """`baro`: abs_pressure hPa, pressure_alt m, temperature degC."""
    return common.MAVLink_hil_sensor_message(t_us, *accel, *gyro, *mag_gauss, baro[0], 0.0, baro[1], baro[2],
                                             updated, sensor_id)


def frame_of(message, mavlink1: bool = False) -> bytes:
    return bytes(message.pack(common.MAVLink(None, srcSystem=1, srcComponent=51), force_mavlink1=mavlink1))


def px4_readings(msg: common.MAVLink_hil_sensor_message) -> codec.SensorReadings:
    """The reference, from pymavlink's decode (its checksum checked): PX4's mavlink_receiver takes a group of
    HIL_SENSOR only when every bit of it is in fields_updated; gauss and hPa to tesla and Pa."""
    def whole(bits: int) -> bool:
        return msg.fields_updated & bits == bits

    return codec.SensorReadings(
        msg.time_usec,
        (msg.xacc, msg.yacc, msg.zacc) if whole(0x007) else None,
        (msg.xgyro, msg.ygyro, msg.zgyro) if whole(0x038) else None,
        tuple(v * 1e-4 for v in (msg.xmag, msg.ymag, msg.zmag)) if whole(0x1C0) else None,
        codec.Baro(msg.abs_pressure * 100.0, msg.temperature, msg.pressure_alt) if whole(0x1A00) else None)


def pymavlink_row(frame: bytes) -> np.ndarray:
    return codec.sensor_row(px4_readings(common.MAVLink(None).decode(bytearray(frame))))


FRAMES = {
    "every group": frame_of(sensor_message(4000, ALL_GROUPS)),
    "IMU only, payload trimmed": frame_of(sensor_message(8000, 0x3F, mag_gauss=(0.0, 0.0, 0.0))),
    "no group, zeros trimmed to the time": frame_of(sensor_message(9000, 0, (0.0,) * 3, (0.0,) * 3, (0.0,) * 3,
                                                                    (0.0,) * 3)),
    "magnetometer bit missing": frame_of(sensor_message(12_000, ALL_GROUPS & ~0x100)),
    "pressure_alt bit missing": frame_of(sensor_message(16_000, ALL_GROUPS & ~0x800)),
    "second IMU (id 1)": frame_of(sensor_message(20_000, ALL_GROUPS, sensor_id=1)),
    "MAVLink 1": frame_of(sensor_message(24_000, ALL_GROUPS), mavlink1=True),
}


@pytest.mark.parametrize("name", FRAMES)
def test_a_frame_reads_into_the_row_pymavlink_and_px4_read(name):
    frame = FRAMES[name]
    row = np.full(hil_frames.ROW_SIZE, np.nan)
    hil_frames.hil_sensor_row(frame, np.zeros(hil_frames.HIL_SENSOR[2], np.uint8), row)
    expected = pymavlink_row(frame)
    fields = slice(hil_frames.ROW_T_US, hil_frames.ROW_PRESENT + 1)  # the fix's part of a row is not HIL_SENSOR's
    assert row[fields].tobytes() == expected[fields].tobytes()


def test_the_trimmed_and_the_mavlink1_frames_are_what_they_say():
    """The cases above are the wire's: MAVLink 2 drops the zeros ending a payload; MAVLink 1's shorter header."""
    trimmed = FRAMES["IMU only, payload trimmed"]
    assert trimmed[0] == 0xFD and trimmed[1] == 61  # fields_updated 0x3F, then its three zero bytes and id 0 trimmed
    assert FRAMES["no group, zeros trimmed to the time"][1] == 2  # 9000 µs = 0x2328: two bytes of time_usec
    assert FRAMES["MAVLink 1"][0] == 0xFE  # its header is 6 bytes, the payload after it


def flight_frames() -> list[bytes]:
    """Two seconds of a vehicle at rest at 250 Hz with noise, every fifth sample without the barometer and every
    seventh without the magnetometer, as PX4 SITL sends them (the groups as they come)."""
    rng = np.random.default_rng(7)
    frames = []
    for k in range(500):
        updated = ALL_GROUPS & ~(0x1A00 if k % 5 == 0 else 0) & ~(0x1C0 if k % 7 == 0 else 0)
        accel = tuple(np.float32(v) for v in np.array((0.0, 0.0, -9.80665)) + rng.normal(0, 0.05, 3))
        gyro = tuple(np.float32(v) for v in rng.normal(0, 0.002, 3))
        frames.append(frame_of(sensor_message(4000 * (k + 1), updated, accel, gyro)))
    return frames


def test_the_estimator_fed_frames_is_bit_for_bit_the_estimator_fed_pymavlinks_readings():
    by_frame, by_readings = Estimator(EstimatorSettings()), Estimator(EstimatorSettings())
    fix = GpsFix(0, 47.397742, 8.545594, 488.0, (0.0, 0.0, 0.0), 0.9, 1.8, 3, 10)
    for estimator in (by_frame, by_readings):
        estimator.on_gps(fix, 0)  # the origin and the magnetic field: alignment can happen
    decoder = common.MAVLink(None)
    for frame in flight_frames():
        estimate = by_frame.on_sensor_frame(frame)
        assert estimate.tobytes() == by_readings.on_sensors(px4_readings(decoder.decode(bytearray(frame)))).tobytes()
    assert by_frame.aligned and by_frame.t_us == by_readings.t_us == 2_000_000
    assert by_frame.x.tobytes() == by_readings.x.tobytes()
    assert np.any(by_frame.x != 0.0)
