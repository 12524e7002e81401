"""HIL codec against values worked out by hand from the spec, and pymavlink as the byte oracle."""

from __future__ import annotations

import pytest
from pymavlink.dialects.v20 import common

from firmware_interface import hil_codec as codec
from firmware_interface.link.encoder import FrameEncoder, message_class

REST = codec.SensorReadings(
    t_us=4000,
    accel_frd=(0.0, 0.0, -9.80665),
    gyro_frd=(0.0, 0.0, 0.0),
    mag_frd_t=(0.21506e-4, 0.01021e-4, 0.42974e-4),  # jMAVSim's Zurich field, in tesla
    baro=codec.Baro(pressure_pa=95_540.0, temperature_degc=11.83, pressure_alt_m=488.0),
)


def pymavlink_frame(name: str, fields: dict, seq: int = 0) -> bytes:
    mav = common.MAVLink(None, srcSystem=1, srcComponent=51)
    mav.seq = seq
    return bytes(message_class(name)(**fields).pack(mav))


def ours(name: str, fields: dict, seq: int = 0) -> bytes:
    encoder = FrameEncoder(1, 51)
    encoder.seq = seq
    return encoder.encode(message_class(name), fields)


def test_hil_sensor_units_and_groups_at_rest():
    f = codec.hil_sensor_fields(REST)
    assert (f["xacc"], f["yacc"], f["zacc"]) == (0.0, 0.0, -9.80665)  # specific force, FRD
    assert f["zmag"] == pytest.approx(0.42974)  # tesla -> gauss
    assert f["abs_pressure"] == pytest.approx(955.40)  # Pa -> hPa
    assert f["fields_updated"] == 0x1BFF  # accel 0x7 | gyro 0x38 | mag 0x1C0 | baro 0x1A00
    imu_only = codec.hil_sensor_fields(codec.SensorReadings(1, (0, 0, -9.8), (0, 0, 0)))
    assert imu_only["fields_updated"] == 0x003F


def test_hil_sensor_frame_equals_pymavlink_and_has_the_documented_size():
    for seq in (0, 200):
        frame = ours("HIL_SENSOR", codec.hil_sensor_fields(REST), seq)
        assert frame == pymavlink_frame("HIL_SENSOR", codec.hil_sensor_fields(REST), seq)
    assert len(ours("HIL_SENSOR", codec.hil_sensor_fields(REST))) == 74  # mask 0x1BFF, id 0 (docs/px4_protocol.md §2.3)
    imu = codec.hil_sensor_fields(codec.SensorReadings(1, (0.1, 0, -9.8), (0.01, 0, 0), sensor_id=0))
    imu["temperature"] = 20.0
    assert len(ours("HIL_SENSOR", imu)) == 73  # mask 0x3F, id 0
    assert len(ours("HIL_SENSOR", dict(imu, id=1))) == 77


def test_hil_sensor_round_trip_and_incomplete_group_is_absent():
    mav = common.MAVLink(None)
    msg = mav.decode(bytearray(ours("HIL_SENSOR", codec.hil_sensor_fields(REST))))
    back = codec.read_hil_sensor(msg)
    assert back.baro.pressure_pa == pytest.approx(95_540.0, rel=1e-6)
    assert back.mag_frd_t[2] == pytest.approx(0.42974e-4, rel=1e-6)
    partial = dict(codec.hil_sensor_fields(REST), fields_updated=0x1BFF & ~0x800)  # pressure_alt bit missing
    msg = mav.decode(bytearray(ours("HIL_SENSOR", partial)))
    assert codec.read_hil_sensor(msg).baro is None  # PX4 drops a group with a missing bit


def test_hil_gps_fields_by_hand():
    fix = codec.GpsFix(t_us=1_000_000, lat_deg=47.397742, lon_deg=8.545594, alt_msl_m=488.0,
                       vel_ned=(0.0, 1.5, -0.25), eph_m=0.9, epv_m=1.78, fix_type=3, satellites=10)
    f = codec.hil_gps_fields(fix)
    assert (f["lat"], f["lon"], f["alt"]) == (473977420, 85455940, 488000)  # degE7, mm MSL
    assert (f["eph"], f["epv"]) == (90, 178)  # accuracy in cm, as PX4 reads them
    assert (f["vn"], f["ve"], f["vd"], f["vel"]) == (0, 150, -25, 150)  # cm/s
    assert f["cog"] == 9000  # flying east: 90.00 deg in cdeg
    assert (f["fix_type"], f["satellites_visible"]) == (3, 10)
    assert ours("HIL_GPS", f) == pymavlink_frame("HIL_GPS", f)
    assert len(ours("HIL_GPS", f)) == 48  # id 0, yaw 0 (docs/px4_protocol.md §2.3)
    west = codec.hil_gps_fields(codec.GpsFix(0, 0, 0, 0, (0.0, -1.0, 0.0), 1, 1))
    assert west["cog"] == 27000


def test_hil_state_quaternion_fields_by_hand():
    truth = codec.GroundTruth(t_us=8000, q_wxyz=(1.0, 0.0, 0.0, 0.0), rates_frd=(0.1, -0.2, 0.3),
                              lat_deg=47.397742, lon_deg=8.545594, alt_msl_m=490.5, vel_ned=(1.0, -2.0, 0.5),
                              specific_force_frd=(0.0, 0.0, -9.80665), airspeed_m_s=2.5)
    f = codec.hil_state_quaternion_fields(truth)
    assert (f["vx"], f["vy"], f["vz"]) == (100, -200, 50)
    assert f["zacc"] == -9807  # m/s^2 x 1000, what PX4 SITL divides by 1000
    assert f["alt"] == 490500 and f["true_airspeed"] == 250
    assert ours("HIL_STATE_QUATERNION", f) == pymavlink_frame("HIL_STATE_QUATERNION", f)


def test_actuator_controls_decode_quad_x_armed_lockstep():
    msg = common.MAVLink_hil_actuator_controls_message(123, [0.61, 0.62, 0.63, 1.4] + [0.0] * 12, 129, 1)
    out = codec.read_actuator_controls(msg)
    assert out.motors == (0.61, 0.62, 0.63, 1.0)  # clipped to the motor range
    assert out.armed and out.lockstep and out.mode == 129
    disarmed = codec.read_actuator_controls(common.MAVLink_hil_actuator_controls_message(1, [0.0] * 16, 1, 0))
    assert not disarmed.armed and not disarmed.lockstep


def test_board_side_actuator_fields_are_zero_while_disarmed():
    f = codec.hil_actuator_controls_fields(5, (0.5, 0.5, 0.5, 0.5), armed=False, lockstep=True)
    assert f["controls"] == [0.0] * 16 and f["mode"] == 1 | 32 and f["flags"] == 1
    armed = codec.hil_actuator_controls_fields(5, (0.5, 0.5, 0.5, 0.5), armed=True, lockstep=True)
    assert armed["mode"] == 1 | 32 | 128
    assert len(ours("HIL_ACTUATOR_CONTROLS", armed)) == 93
