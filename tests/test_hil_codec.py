"""HIL codec against values worked out by hand from the spec, and pymavlink as the byte oracle."""

from __future__ import annotations

import numpy as np
import pytest
from pymavlink.dialects.v20 import common

from firmware_interface import hil_codec as codec
from firmware_interface import hil_frames
from firmware_interface.link.encoder import FrameEncoder, message_class
from firmware_interface.link.light_messages import LIGHT

REST = codec.SensorReadings(
    t_us=4000,
    accel_frd=(0.0, 0.0, -9.80665),
    gyro_frd=(0.0, 0.0, 0.0),
    mag_frd_t=(0.21506e-4, 0.01021e-4, 0.42974e-4),  # jMAVSim's Zurich field, in tesla
    baro=codec.Baro(pressure_pa=95_540.0, temperature_degc=11.83, pressure_alt_m=488.0),
)


def ours(packer, *fields, seq: int = 0) -> bytes:
    """A frame of ours (system 1, component 51, as the bench's sender) from a compiled packer."""
    buffer = np.zeros(512, dtype=np.uint8)
    return buffer[:packer(buffer, seq, 1, 51, *fields)].tobytes()


def decoded(frame: bytes):
    """The frame as pymavlink reads it (its checksum checked)."""
    return common.MAVLink(None).decode(bytearray(frame))


def pymavlink_frame(message, seq: int = 0) -> bytes:
    """pymavlink's own frame of the same message: the byte oracle."""
    mav = common.MAVLink(None, srcSystem=1, srcComponent=51)
    mav.seq = seq
    return bytes(message.pack(mav))


def test_hil_sensor_units_and_groups_at_rest():
    f = decoded(ours(hil_frames.encode_hil_sensor, codec.sensor_row(REST)))
    assert (f.xacc, f.yacc, f.zacc) == (0.0, 0.0, np.float32(-9.80665))  # specific force, FRD, float32 on the wire
    assert f.zmag == pytest.approx(0.42974)  # tesla -> gauss
    assert f.abs_pressure == pytest.approx(955.40)  # Pa -> hPa
    assert f.fields_updated == 0x1BFF  # accel 0x7 | gyro 0x38 | mag 0x1C0 | baro 0x1A00
    imu_only = decoded(ours(hil_frames.encode_hil_sensor, codec.sensor_row(codec.SensorReadings(1, (0, 0, -9.8),
                                                                                                   (0, 0, 0)))))
    assert imu_only.fields_updated == 0x003F


def test_hil_sensor_frame_equals_pymavlink_and_has_the_documented_size():
    for seq in (0, 200):
        frame = ours(hil_frames.encode_hil_sensor, codec.sensor_row(REST), seq=seq)
        assert frame == pymavlink_frame(decoded(frame), seq)
    assert len(ours(hil_frames.encode_hil_sensor, codec.sensor_row(REST))) == 74  # mask 0x1BFF, id 0 (§2.3)
    imu = codec.SensorReadings(1, (0.1, 0, -9.8), (0.01, 0, 0))
    assert len(ours(hil_frames.encode_hil_sensor, codec.sensor_row(imu))) == 73  # mask 0x3F, id 0: zeros trimmed


def read_row(frame: bytes) -> np.ndarray:
    """The row a board reads from a HIL_SENSOR frame (`hil_frames.hil_sensor_row`)."""
    row = np.zeros(hil_frames.ROW_SIZE)
    hil_frames.hil_sensor_row(frame, np.zeros(hil_frames.HIL_SENSOR[2], np.uint8), row)
    return row


def test_hil_sensor_round_trip_and_incomplete_group_is_absent():
    frame = ours(hil_frames.encode_hil_sensor, codec.sensor_row(REST))
    back = read_row(frame)
    assert back[hil_frames.ROW_BARO] == pytest.approx(95_540.0, rel=1e-6)
    assert back[hil_frames.ROW_MAG_T + 2] == pytest.approx(0.42974e-4, rel=1e-6)
    msg = decoded(frame)
    msg.fields_updated = 0x1BFF & ~0x800  # pressure_alt bit missing
    no_baro = read_row(pymavlink_frame(msg))
    assert int(no_baro[hil_frames.ROW_PRESENT]) == hil_frames.HAS_ACCEL | hil_frames.HAS_GYRO | hil_frames.HAS_MAG
    assert no_baro[hil_frames.ROW_BARO] == 0.0  # PX4 drops a group with a missing bit


def test_a_rows_readings_and_fix_come_back_as_they_went_in():
    fix = codec.GpsFix(t_us=996_000, lat_deg=47.397742, lon_deg=8.545594, alt_msl_m=488.0, vel_ned=(0.0, 1.5, -0.25),
                       eph_m=0.9, epv_m=1.78, fix_type=3, satellites=10)
    assert codec.readings_of_row(codec.sensor_row(REST, fix)) == (REST, fix)
    assert codec.readings_of_row(codec.sensor_row(REST)) == (REST, None)


def test_hil_gps_fields_by_hand():
    fix = codec.GpsFix(t_us=1_000_000, lat_deg=47.397742, lon_deg=8.545594, alt_msl_m=488.0,
                       vel_ned=(0.0, 1.5, -0.25), eph_m=0.9, epv_m=1.78, fix_type=3, satellites=10)
    frame = ours(hil_frames.encode_hil_gps, codec.sensor_row(REST, fix))
    f = decoded(frame)
    assert (f.time_usec, f.lat, f.lon, f.alt) == (1_000_000, 473977420, 85455940, 488000)  # degE7, mm MSL
    assert (f.eph, f.epv) == (90, 178)  # accuracy in cm, as PX4 reads them
    assert (f.vn, f.ve, f.vd, f.vel) == (0, 150, -25, 150)  # cm/s
    assert f.cog == 9000  # flying east: 90.00 deg in cdeg
    assert (f.fix_type, f.satellites_visible) == (3, 10)
    assert frame == pymavlink_frame(f)
    assert len(frame) == 48  # id 0, yaw 0 (docs/px4_protocol.md §2.3)
    west = codec.GpsFix(0, 0, 0, 0, (0.0, -1.0, 0.0), 1, 1)
    assert decoded(ours(hil_frames.encode_hil_gps, codec.sensor_row(REST, west))).cog == 27000


def test_hil_state_quaternion_fields_by_hand():
    frame = ours(hil_frames.encode_hil_state_quaternion, 8000, np.array((1.0, 0.0, 0.0, 0.0)),
                 np.array((0.1, -0.2, 0.3)), np.array((47.397742, 8.545594, 490.5)), np.array((1.0, -2.0, 0.5)),
                 np.array((0.0, 0.0, -9.80665)), 2.5)
    f = decoded(frame)
    assert (f.vx, f.vy, f.vz) == (100, -200, 50)
    assert f.zacc == -9807  # m/s^2 x 1000, what PX4 SITL divides by 1000
    assert f.alt == 490500 and f.true_airspeed == 250 and (f.lat, f.lon) == (473977420, 85455940)
    assert frame == pymavlink_frame(f)


def test_setpoint_fields_by_hand():
    frame = ours(hil_frames.encode_setpoint, 100, 1, 1, np.array((1.0, 2.0, -3.0)), np.array((0.1, -0.2, 0.3)),
                 np.array((0.0, 0.5, 0.0)), 0.5)
    f = decoded(frame)
    # MAVLink common.xml: MAV_FRAME_LOCAL_NED = 1; POSITION_TARGET_TYPEMASK bit 11 (2048) ignores the yaw rate
    assert (f.time_boot_ms, f.coordinate_frame, f.type_mask) == (100, 1, 2048)
    assert (f.target_system, f.target_component) == (1, 1)
    assert (f.x, f.y, f.z, f.yaw) == pytest.approx((1.0, 2.0, -3.0, 0.5))
    assert frame == pymavlink_frame(f)


def test_board_side_actuator_fields_are_zero_while_disarmed():
    f = codec.hil_actuator_controls_fields(5, (0.5, 0.5, 0.5, 0.5), armed=False, lockstep=True)
    assert f["controls"] == [0.0] * 16 and f["mode"] == 1 | 32 and f["flags"] == 1
    armed = codec.hil_actuator_controls_fields(5, (0.5, 0.5, 0.5, 0.5), armed=True, lockstep=True)
    assert armed["mode"] == 1 | 32 | 128
    assert len(FrameEncoder(1, 51).encode(message_class("HIL_ACTUATOR_CONTROLS"), armed)) == 93


@pytest.mark.parametrize("message", [common.MAVLink_hil_sensor_message, common.MAVLink_hil_gps_message,
                                     common.MAVLink_set_position_target_local_ned_message,
                                     common.MAVLink_odometry_message, common.MAVLink_hil_state_quaternion_message,
                                     common.MAVLink_hil_actuator_controls_message, common.MAVLink_attitude_message,
                                     common.MAVLink_local_position_ned_message,
                                     common.MAVLink_attitude_target_message, common.MAVLink_debug_float_array_message,
                                     common.MAVLink_extended_sys_state_message], ids=lambda m: m.msgname)
def test_a_light_message_reads_what_pymavlink_reads(message):
    """Every field of frames packed by pymavlink with random values (zeros among them, so that MAVLink 2 trims
    the payload; texts of any bytes and every length up to the field's, so that some end without a NUL and some
    are not ASCII), decoded both ways; and what the bench and the emulator ask of a message."""
    rng = np.random.default_rng(message.id)
    lengths = dict(zip(message.ordered_fieldnames, message.array_lengths, strict=True))
    limits = {"float": None, "uint64_t": (0, 2**63), "uint32_t": (0, 2**32), "int32_t": (-2**31, 2**31),
              "uint16_t": (0, 2**16), "int16_t": (-2**15, 2**15), "uint8_t": (0, 256), "int8_t": (-128, 128)}

    def value(kind: str) -> float | int:
        if rng.random() < 0.3:
            return 0
        bounds = limits[kind]
        return float(np.float32(rng.normal(0, 100))) if bounds is None else int(rng.integers(*bounds))

    def text(length: int) -> bytes:
        return bytes(int(rng.integers(1, 256)) for _ in range(int(rng.integers(0, length + 1))))

    mav = common.MAVLink(None, srcSystem=7, srcComponent=9)
    for _ in range(100):
        fields = [text(lengths[name]) if kind == "char" else
                  [value(kind) for _ in range(lengths[name])] if lengths[name] > 1 else value(kind)
                  for name, kind in zip(message.fieldnames, message.fieldtypes, strict=True)]
        frame = bytes(message(*fields).pack(mav))
        light, reference = LIGHT[message.id](frame), common.MAVLink(None).decode(bytearray(frame))
        numbers = [name for name in message.fieldnames if not isinstance(getattr(reference, name), str)]
        assert [getattr(light, name) for name in message.fieldnames] == [
            getattr(reference, name) for name in message.fieldnames]
        assert [getattr(light, name) for name in numbers] == [
            field for name, field in zip(message.fieldnames, fields, strict=True) if name in numbers]
        assert (light.get_type(), light.get_srcSystem(), light.get_srcComponent()) == (message.msgname, 7, 9)
        assert bytes(light.get_msgbuf()) == frame
