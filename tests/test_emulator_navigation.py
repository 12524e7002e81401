"""The emulator's ground-station parts in process, against facts from PX4 v1.15.4's source and the MAVLink
spec, and hand-derived maths: mode numbers, mission items, the return altitude, references, setpoint masks."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest
from pymavlink.dialects.v20 import common
from pymavlink.dialects.v20.common import (
    MAV_CMD_DO_CHANGE_SPEED,
    MAV_CMD_NAV_LOITER_UNLIM,
    MAV_CMD_NAV_RETURN_TO_LAUNCH,
    MAV_CMD_NAV_WAYPOINT,
    MAV_FRAME_GLOBAL_INT,
    MAV_FRAME_GLOBAL_RELATIVE_ALT,
    MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
    MAV_FRAME_LOCAL_NED,
    MAV_FRAME_MISSION,
)

from firmware_interface.emulator.commander import base_mode_flags, mode_from_set_mode
from firmware_interface.emulator.control import Setpoint
from firmware_interface.emulator.mission_items import MissionItem, item_fields, parse_item
from firmware_interface.emulator.mission_protocol import _crc32_item
from firmware_interface.emulator.offboard import OffboardInput
from firmware_interface.emulator.px4_params import Px4Values
from firmware_interface.emulator.return_run import return_altitude
from firmware_interface.emulator.trajectory import Limits, Move, quintic_sample
from firmware_interface.px4_modes import FlightMode, mode_name

MAV = common.MAVLink(None, srcSystem=255, srcComponent=190)
NAN = float("nan")


def test_mode_numbers_are_px4_custom_mode_h():
    """px4_custom_mode.h: main modes MANUAL 1, POSCTL 3, AUTO 4, OFFBOARD 6; AUTO sub modes TAKEOFF 2,
    LOITER 3, MISSION 4, RTL 5, LAND 6; custom_mode = main << 16 | sub << 24 (union: reserved u16, main u8, sub u8)."""
    expected = {FlightMode.MANUAL: 0x0001_0000, FlightMode.POSCTL: 0x0003_0000, FlightMode.OFFBOARD: 0x0006_0000,
                FlightMode.AUTO_TAKEOFF: 0x0204_0000, FlightMode.AUTO_LOITER: 0x0304_0000,
                FlightMode.AUTO_MISSION: 0x0404_0000, FlightMode.AUTO_RTL: 0x0504_0000,
                FlightMode.AUTO_LAND: 0x0604_0000}
    assert {mode: int(mode) for mode in FlightMode} == expected
    assert [mode_name(m) for m in expected.values()] == ["MANUAL", "POSCTL", "OFFBOARD", "AUTO.TAKEOFF", "AUTO.LOITER",
                                                         "AUTO.MISSION", "AUTO.RTL", "AUTO.LAND"]
    assert mode_name(0x0002_0000) == "ALTCTL" and mode_name(0x0009_0000) == "0x00090000"


def test_do_set_mode_is_read_as_commander_reads_it():
    """Commander.cpp: custom flag 1 with main/sub mode; AUTO without sub mode is MISSION; without the custom flag,
    AUTO_ENABLED (4) means mission, MANUAL_INPUT (64) + GUIDED (8) position control, MANUAL_INPUT alone manual."""
    assert mode_from_set_mode(1, 4, 0) is FlightMode.AUTO_MISSION
    assert mode_from_set_mode(1, 4, 5) is FlightMode.AUTO_RTL
    assert mode_from_set_mode(1, 6, 0) is FlightMode.OFFBOARD
    assert mode_from_set_mode(1, 4, 1) is None  # AUTO.READY: "Unsupported auto mode"
    assert mode_from_set_mode(1, 2, 0) is None  # ALTCTL: not flown by the emulator
    assert mode_from_set_mode(4, 0, 0) is FlightMode.AUTO_MISSION
    assert mode_from_set_mode(64 | 8, 0, 0) is FlightMode.POSCTL
    assert mode_from_set_mode(64, 0, 0) is FlightMode.MANUAL


def test_heartbeat_flags_are_px4s_per_control_mode():
    """HEARTBEAT.hpp with ModeUtil/control_mode.cpp: auto modes set AUTO 4 | GUIDED 8 | STABILIZE 16, position
    control MANUAL_INPUT 64 | STABILIZE 16, offboard position control STABILIZE 16."""
    assert base_mode_flags(FlightMode.AUTO_RTL) == 4 | 8 | 16
    assert base_mode_flags(FlightMode.POSCTL) == 64 | 16
    assert base_mode_flags(FlightMode.OFFBOARD) == 16


def item(frame: int, command: int, x: float = 0, y: float = 0, z: float = 0, params=(0.0, 0.0, 0.0, NAN),
         int_encoded: bool = True):
    encode = MAV.mission_item_int_encode if int_encoded else MAV.mission_item_encode
    return encode(1, 1, 0, frame, command, 0, 1, *params, x, y, z, 0)


def test_mission_items_are_taken_and_refused_as_px4_parses_them():
    """mavlink_mission.cpp parse_mavlink_mission_item: global frames for position items (the _INT frames only in
    MISSION_ITEM_INT), MAV_FRAME_MISSION for DO_CHANGE_SPEED and RETURN_TO_LAUNCH, MAV_MISSION_UNSUPPORTED_FRAME (2)
    for any other frame, MAV_MISSION_UNSUPPORTED (3) for a command (here: one the emulator does not fly)."""
    waypoint = parse_item(item(MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, MAV_CMD_NAV_WAYPOINT, 473977420, 85455940, 10,
                               (2.0, 1.5, 0.0, -90.0)), True)
    assert isinstance(waypoint, MissionItem)
    assert (waypoint.lat_deg, waypoint.lon_deg, waypoint.altitude_m, waypoint.relative_alt) == pytest.approx(
        (47.397742, 8.545594, 10.0, True))
    assert waypoint.hold_s == 2.0 and waypoint.acceptance_radius_m == 1.5
    assert waypoint.params[3] == pytest.approx(270.0)  # PX4 keeps yaw as wrap_2pi(radians(param4))
    assert parse_item(item(MAV_FRAME_MISSION, MAV_CMD_DO_CHANGE_SPEED, params=(1, 3.0, -1, 0)), True).params[1] == 3.0
    assert isinstance(parse_item(item(MAV_FRAME_MISSION, MAV_CMD_NAV_RETURN_TO_LAUNCH), True), MissionItem)
    assert parse_item(item(MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, MAV_CMD_NAV_RETURN_TO_LAUNCH), True) == 3
    assert parse_item(item(MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, MAV_CMD_NAV_LOITER_UNLIM), True) == 3
    assert parse_item(item(MAV_FRAME_LOCAL_NED, MAV_CMD_NAV_WAYPOINT), True) == 2
    assert parse_item(item(MAV_FRAME_GLOBAL_INT, MAV_CMD_NAV_WAYPOINT, int_encoded=False), False) == 2
    floating = parse_item(item(MAV_FRAME_GLOBAL_RELATIVE_ALT, MAV_CMD_NAV_WAYPOINT, 47.5, 8.5, 5,
                               int_encoded=False), False)
    assert isinstance(floating, MissionItem) and floating.lat_deg == 47.5


def test_a_downloaded_item_carries_what_was_uploaded_in_the_asked_encoding():
    """format_mavlink_mission_item: x, y as degE7 in the _INT messages, the frame switched to its _INT twin."""
    stored = parse_item(item(MAV_FRAME_GLOBAL_RELATIVE_ALT, MAV_CMD_NAV_WAYPOINT, 47.5, 8.25, 5, int_encoded=False),
                        False)
    assert isinstance(stored, MissionItem)
    fields = item_fields(stored, 3, True, int_encoded=True)
    assert (fields["x"], fields["y"], fields["z"], fields["frame"]) == (475000000, 82500000, 5.0, 6)
    assert (fields["seq"], fields["current"], fields["command"]) == (3, 1, MAV_CMD_NAV_WAYPOINT)
    assert math.isnan(fields["param4"])


def nuttx_crc32part(data: bytes, crc: int) -> int:
    """NuttX's crc32part written out bit by bit: reflected polynomial 0xEDB88320, no pre- or post-inversion."""
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = (crc >> 1) ^ (0xEDB88320 if crc & 1 else 0)
    return crc


def test_the_mission_crc_is_px4s_crc32_over_the_packed_items():
    msg = item(MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, MAV_CMD_NAV_WAYPOINT, 473977420, 85455940, 10.0, (0, 0, 0, 0))
    packed = struct.pack("<BHB4fiif", 6, 16, 1, 0, 0, 0, 0, 473977420, 85455940, 10.0)  # CrcMissionItem_t
    assert _crc32_item(msg, True, 0) == nuttx_crc32part(packed, 0)
    assert _crc32_item(msg, True, 0x1234) == nuttx_crc32part(packed, 0x1234)


@pytest.mark.parametrize(("distance", "height", "expected"), [
    (1.0, 5.0, 5.0),  # within NAV_ACC_RAD: 2·distance = 2, never lower than the vehicle
    (6.0, 1.0, 6.0),  # within RTL_MIN_DIST: the 45° cone, 6/tan 45° = 6 (above 2·NAV_ACC_RAD = 4)
    (3.0, 0.5, 4.0),  # the cone asks 3, but at least 2·NAV_ACC_RAD
    (50.0, 10.0, 30.0),  # far: RTL_RETURN_ALT
    (50.0, 40.0, 40.0),  # already higher: stays
])
def test_return_altitude_is_rtl_cpp_cone(distance, height, expected):
    """RTL.cpp calculate_return_alt_from_cone_half_angle with the multicopter defaults (NAV_ACC_RAD 2, RTL_MIN_DIST
    10, RTL_CONE_ANG 45, RTL_RETURN_ALT 30)."""
    home = np.array((0.0, 0.0, 0.0))
    assert return_altitude(Px4Values(), home, np.array((distance, 0.0, -height))) == pytest.approx(expected)
    assert return_altitude(Px4Values({"RTL_CONE_ANG": 0}), home, np.array((3.0, 0.0, -1.0))) == 30.0


LIMITS = Limits(speed_xy=5.0, speed_up=3.0, speed_down=1.5, accel_xy=3.0, accel_up=4.0, accel_down=3.0,
                yaw_rate=math.radians(45))


def samples(move: Move, start_us: int = 0) -> list[Setpoint]:
    steps = round(move.duration_s / 0.004) + 10
    return [move.sample(start_us + k * 4000, 0.004) for k in range(steps)]


def test_a_rest_to_rest_move_keeps_px4s_limits_and_ends_at_rest_on_target():
    """10 m north: T = max(1.875·10/5, sqrt(5.774·10/3)) = 4.387 s, so the peak acceleration is MPC_ACC_HOR = 3 and
    the peak speed 1.875·10/4.387 = 4.27 m/s (both hand-computed from the quintic smoothstep)."""
    start = Setpoint(np.zeros(3), np.zeros(3), np.zeros(3), 0.0)
    move = Move(start, 0, np.array((10.0, 0.0, 0.0)), math.pi / 2, LIMITS)
    assert move.duration_s == pytest.approx(math.sqrt(10 / math.sqrt(3) * 10 / 3), rel=1e-9)
    trace = samples(move)
    speeds = [float(np.linalg.norm(s.vel_ned)) for s in trace]
    accels = [float(np.linalg.norm(s.acc_ned)) for s in trace]
    assert max(speeds) == pytest.approx(1.875 * 10 / move.duration_s, rel=1e-3)
    assert max(accels) == pytest.approx(3.0, rel=1e-3)
    end = trace[-1]
    assert end.pos_ned == pytest.approx((10, 0, 0)) and end.vel_ned == pytest.approx((0, 0, 0), abs=1e-12)
    assert end.yaw == pytest.approx(math.pi / 2)
    yaw_rates = np.diff([s.yaw for s in trace]) / 0.004
    assert max(abs(yaw_rates)) <= math.radians(45) * 1.001  # MPC_YAWRAUTO_MAX


def test_a_move_from_a_moving_reference_is_continuous():
    """The next leg starts where the reference is, with its velocity and acceleration: no step in any of them."""
    start = Setpoint(np.array((1.0, 2.0, -5.0)), np.array((4.0, 0.0, 0.0)), np.array((-1.0, 0.5, 0.0)), 0.0)
    move = Move(start, 1_000_000, np.array((5.0, 10.0, -5.0)), None, LIMITS)
    first = move.sample(1_000_000, 0.004)
    assert (first.pos_ned, first.vel_ned, first.acc_ned) == (pytest.approx(start.pos_ned),
                                                             pytest.approx(start.vel_ned), pytest.approx(start.acc_ned))
    _, vel, _ = quintic_sample(move.coeffs, 0.002)  # central difference of position ≈ velocity
    back, _, _ = quintic_sample(move.coeffs, 0.0)
    ahead, _, _ = quintic_sample(move.coeffs, 0.004)
    assert (ahead - back) / 0.004 == pytest.approx(vel, abs=1e-4)


def setpoint_message(type_mask: int, frame: int = MAV_FRAME_LOCAL_NED):
    return MAV.set_position_target_local_ned_encode(0, 1, 1, frame, type_mask, 1, 2, -3, 0.5, 0, 0, 0, 0, 0, 0.7, 0)


def test_offboard_type_mask_is_honoured():
    """POSITION_TARGET_TYPEMASK: bits 0-2 position, 3-5 velocity, 6-8 acceleration, 10 yaw, 11 yaw rate ignored.
    MAVSDK's set_position_ned sends 0b1001_1111_1000, set_velocity_ned 0b1001_1100_0111 (offboard_impl.cpp)."""
    board = OffboardInput()
    board.receive(setpoint_message(0b1000_0000_0000), 10)  # the bench's: only yaw rate ignored
    assert board.kind == "full" and board.setpoint is not None and board.setpoint.vel_ned[0] == 0.5
    board.receive(setpoint_message(0b1001_1111_1000), 20)
    assert board.kind == "position" and board.yaw == pytest.approx(0.7) and board.changes == 1
    board.receive(setpoint_message(0b1001_1111_1000), 30)
    assert board.changes == 1  # the same target again is no new target
    board.receive(setpoint_message(0b1101_1100_0111), 40)
    assert board.kind == "velocity" and board.yaw is None and board.received_us == 40
    board.receive(setpoint_message(0b1000_0000_0000, frame=8), 50)  # MAV_FRAME_BODY_NED: not flown
    assert board.received_us == 40
    assert board.fresh(40 + 1_000_000, 1.0) and not board.fresh(40 + 1_000_001, 1.0)
