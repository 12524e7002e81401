"""The emulator as a ground station meets it: real MAVLink bytes over a real pty, pymavlink packing the GCS's
frames (system 255, component 190). The mission protocol against the MAVLink spec's sequences and PX4 v1.15.4's
answers (mavlink_mission.cpp), commands against Commander.cpp's COMMAND_ACK results, HEARTBEAT modes against
px4_custom_mode.h, the telemetry MAVSDK's health checks read."""

from __future__ import annotations

import math
import time
from itertools import pairwise

import pytest
from pymavlink.dialects.v20 import common
from pymavlink.dialects.v20.common import (
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_CMD_DO_CHANGE_SPEED,
    MAV_CMD_DO_SET_MISSION_CURRENT,
    MAV_CMD_DO_SET_MODE,
    MAV_CMD_DO_SET_SERVO,
    MAV_CMD_MISSION_START,
    MAV_CMD_NAV_LAND,
    MAV_CMD_NAV_LOITER_UNLIM,
    MAV_CMD_NAV_RETURN_TO_LAUNCH,
    MAV_CMD_NAV_TAKEOFF,
    MAV_CMD_NAV_WAYPOINT,
    MAV_CMD_REQUEST_MESSAGE,
    MAV_CMD_SET_MESSAGE_INTERVAL,
    MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
    MAV_MISSION_ACCEPTED,
    MAV_MISSION_TYPE_FENCE,
    MAV_MISSION_TYPE_RALLY,
    MAV_MISSION_UNSUPPORTED,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_DENIED,
    MAV_RESULT_TEMPORARILY_REJECTED,
    MAV_RESULT_UNSUPPORTED,
    MAV_SYS_STATUS_PREARM_CHECK,
    MAV_SYS_STATUS_SENSOR_3D_ACCEL,
    MAV_SYS_STATUS_SENSOR_3D_GYRO,
    MAV_SYS_STATUS_SENSOR_3D_MAG,
    MAV_SYS_STATUS_SENSOR_GPS,
)

from tests.support.emulator_world import World

pytestmark = pytest.mark.e2e  # the emulator in its own process
NAN = float("nan")
SETTLE_S = 4.0  # the estimator settles on 2 s of good data after its first fix (EstimatorSettings.settle_s)
HOME_POSITION, SYS_STATUS = 242, 1


@pytest.fixture
def world(tmp_path):
    w = World(tmp_path)
    yield w
    w.close()


def waypoints(world: World, points: list[tuple[float, float]], altitude: float = 5.0) -> list:
    items = []
    for seq, (north, east) in enumerate(points):
        lat, lon = world.geodetic(north, east)
        items.append(world.gcs.mission_item_int_encode(1, 1, seq, MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                                                        MAV_CMD_NAV_WAYPOINT, 0, 1, 0, 0, 0, NAN, lat, lon, altitude,
                                                        0))
    return items


def test_upload_follows_the_spec_sequence_and_download_returns_the_items(world):
    items = waypoints(world, [(10, 0), (10, 10), (0, 10)])
    requests, ack = world.upload(items)
    # MISSION_COUNT → one request per item, in order, to the GCS that counted; the last item → MISSION_ACK
    assert [r.seq for r in requests] == [0, 1, 2]
    assert all((r.target_system, r.target_component, r.mission_type) == (255, 190, 0) for r in requests)
    # PX4 after boot asks in its float mode first, then follows the _INT items it is sent
    assert [r.get_type() for r in requests] == ["MISSION_REQUEST", "MISSION_REQUEST_INT", "MISSION_REQUEST_INT"]
    assert ack is not None and (ack.type, ack.mission_type, ack.target_system) == (MAV_MISSION_ACCEPTED, 0, 255)
    got = world.download()
    assert [(i.seq, i.x, i.y, i.z, i.frame, i.command) for i in got] == [
        (i.seq, i.x, i.y, i.z, i.frame, i.command) for i in items]
    assert [i.current for i in got] == [1, 0, 0]  # MISSION_ITEM_INT.current marks the current item


def test_an_item_the_emulator_does_not_fly_is_refused_and_the_mission_kept(world):
    world.upload(waypoints(world, [(5, 0)]))
    items = waypoints(world, [(10, 0), (20, 0)])
    lat, lon = world.geodetic(10, 10)
    items[1] = world.gcs.mission_item_int_encode(1, 1, 1, MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, MAV_CMD_NAV_LOITER_UNLIM,
                                                 0, 1, 0, 0, 0, NAN, lat, lon, 5.0, 0)
    requests, ack = world.upload(items)
    assert [r.seq for r in requests] == [0, 1]
    assert ack is not None and ack.type == MAV_MISSION_UNSUPPORTED
    assert "IGN MISSION_ITEM: Invalid item" in world.texts()
    assert len(world.download()) == 1  # the earlier mission stands


def test_clear_all_empties_the_mission_and_fence_and_rally_are_empty(world):
    world.upload(waypoints(world, [(5, 0), (5, 5)]))
    world.send(world.gcs.mission_clear_all_encode(1, 1, 0))
    acks = [m for m in world.pump(0.3) if m.get_type() == "MISSION_ACK"]
    assert [(a.type, a.mission_type) for a in acks] == [(MAV_MISSION_ACCEPTED, 0)]
    assert world.download() == []
    for kind in (MAV_MISSION_TYPE_FENCE, MAV_MISSION_TYPE_RALLY):  # PX4 with none configured: an empty list
        assert world.download(kind) == []
    fence = [world.gcs.mission_item_int_encode(1, 1, seq, 0, 5003, 0, 1, 4, 0, 0, 0, 473977420, 85455940, 0,
                                               MAV_MISSION_TYPE_FENCE) for seq in range(4)]  # polygon inclusion
    requests, ack = world.upload(fence, MAV_MISSION_TYPE_FENCE)
    assert [r.mission_type for r in requests] == [1] * 4 and ack is not None and ack.type == MAV_MISSION_ACCEPTED
    assert world.download() == []  # the fence is accepted and ignored; the mission is not touched


@pytest.mark.slow
def test_an_upload_that_stops_is_asked_again_every_quarter_second_then_times_out(world):
    """mavlink_mission.cpp: the missing item re-requested every 0.25 s (MAVLINK_MISSION_RETRY_TIMEOUT_DEFAULT); no
    message for 5 s (MAVLINK_MISSION_PROTOCOL_TIMEOUT_DEFAULT): "Operation timeout", and the board is free again."""
    items = waypoints(world, [(5, 0), (5, 5)])
    world.send(world.gcs.mission_count_encode(1, 1, 2, 0))
    started = time.monotonic()
    asked: list[tuple[float, int]] = []
    while time.monotonic() - started < 6.0:
        for msg in world.pump(0.02):
            if msg.get_type() in ("MISSION_REQUEST", "MISSION_REQUEST_INT"):
                asked.append((time.monotonic() - started, msg.seq))
                if msg.seq == 0 and len(asked) == 1:
                    world.send(items[0])  # item 0 once; item 1 never
        if "Operation timeout" in world.texts():
            break
    timed_out = time.monotonic() - started
    repeats = [t for t, seq in asked if seq == 1]
    assert 4.9 < timed_out < 5.6
    assert len(repeats) >= 15 and all(0.2 < b - a < 0.4 for a, b in pairwise(repeats))
    requests, ack = world.upload(items)
    assert ack is not None and ack.type == MAV_MISSION_ACCEPTED and len(requests) == 2


def test_set_current_moves_the_current_item(world):
    world.upload(waypoints(world, [(5, 0), (5, 5), (0, 5)]))
    world.send(world.gcs.mission_set_current_encode(1, 1, 2))
    current = [m for m in world.pump(0.3) if m.get_type() == "MISSION_CURRENT"]
    assert current and (current[-1].seq, current[-1].total) == (2, 3)
    world.send(world.gcs.mission_set_current_encode(1, 1, 7))
    world.pump(0.3)
    assert "WPM: WP CURR CMD: Not in list" in world.texts()
    assert [i.current for i in world.download()] == [0, 0, 1]


def ack_of(world: World, command: int, *params: float) -> int:
    world.command(command, *params)
    for _ in range(50):
        world.step()
        acks = [m for m in world.messages("COMMAND_ACK", world.t_us - 4000) if m.command == command]
        if acks:
            assert (acks[-1].target_system, acks[-1].target_component) == (255, 190)
            return acks[-1].result
    raise AssertionError(f"no COMMAND_ACK for {command}")


def mode_now(world: World) -> int:
    world.run(1.05)
    return world.messages("HEARTBEAT")[-1].custom_mode


def test_commands_are_answered_as_px4s_commander_answers_them(world):
    """While disarmed PX4 takes any mode change (UserModeIntention::change); the emulator's HEARTBEAT shows it."""
    assert ack_of(world, MAV_CMD_COMPONENT_ARM_DISARM, 1) == MAV_RESULT_DENIED  # estimator not settled yet
    assert ack_of(world, MAV_CMD_MISSION_START, 0, 0) == MAV_RESULT_DENIED
    assert "Mission start denied! No valid mission" in world.texts()
    for main, sub, mode in ((4, 3, 0x0304_0000), (4, 2, 0x0204_0000), (4, 5, 0x0504_0000), (4, 6, 0x0604_0000),
                            (4, 4, 0x0404_0000), (6, 0, 0x0006_0000), (1, 0, 0x0001_0000), (3, 0, 0x0003_0000)):
        assert ack_of(world, MAV_CMD_DO_SET_MODE, 1, main, sub) == MAV_RESULT_ACCEPTED
        assert mode_now(world) == mode
    assert ack_of(world, MAV_CMD_DO_SET_MODE, 1, 4, 1) == MAV_RESULT_TEMPORARILY_REJECTED
    assert "Unsupported auto mode" in world.texts()
    assert ack_of(world, MAV_CMD_NAV_TAKEOFF, 0, 0, 0, NAN, NAN, NAN, NAN) == MAV_RESULT_ACCEPTED
    assert mode_now(world) == 0x0204_0000
    assert ack_of(world, MAV_CMD_NAV_LAND) == MAV_RESULT_ACCEPTED
    assert ack_of(world, MAV_CMD_COMPONENT_ARM_DISARM, 1) == MAV_RESULT_TEMPORARILY_REJECTED  # Land forbids arming
    assert "Arming denied: Resolve system health failures first" in world.texts()
    assert ack_of(world, MAV_CMD_NAV_RETURN_TO_LAUNCH) == MAV_RESULT_ACCEPTED
    assert ack_of(world, MAV_CMD_DO_CHANGE_SPEED, 1, 3, -1) == MAV_RESULT_ACCEPTED
    assert ack_of(world, MAV_CMD_SET_MESSAGE_INTERVAL, 33, 100_000) == MAV_RESULT_ACCEPTED
    assert ack_of(world, MAV_CMD_DO_SET_MISSION_CURRENT, 3) == MAV_RESULT_DENIED  # no mission
    assert ack_of(world, MAV_CMD_DO_SET_SERVO, 1, 1500) == MAV_RESULT_UNSUPPORTED
    assert ack_of(world, MAV_CMD_REQUEST_MESSAGE, 9999) == MAV_RESULT_DENIED


def test_armed_commands_and_the_streams_a_ground_station_reads(world):
    world.run(SETTLE_S)
    status = world.messages("SYS_STATUS")[-1]
    needed = (MAV_SYS_STATUS_SENSOR_3D_GYRO | MAV_SYS_STATUS_SENSOR_3D_ACCEL | MAV_SYS_STATUS_SENSOR_3D_MAG
              | MAV_SYS_STATUS_SENSOR_GPS)
    # MAVSDK's telemetry_impl.cpp: present and healthy bits for the sensors and GPS, PREARM_CHECK for is_armable
    assert status.onboard_control_sensors_present & needed == needed
    assert status.onboard_control_sensors_health & (needed | MAV_SYS_STATUS_PREARM_CHECK) == \
        needed | MAV_SYS_STATUS_PREARM_CHECK
    assert ack_of(world, MAV_CMD_REQUEST_MESSAGE, HOME_POSITION) == MAV_RESULT_ACCEPTED  # home set before arming
    home = world.messages("HOME_POSITION")[-1]
    assert (home.latitude, home.longitude) == pytest.approx(world.geodetic(0, 0), abs=20)  # ±2e-6°, 0.2 m
    assert ack_of(world, MAV_CMD_COMPONENT_ARM_DISARM, 1) == MAV_RESULT_ACCEPTED
    world.run(1.05)
    assert world.armed and world.messages("HEARTBEAT")[-1].base_mode & 128
    assert ack_of(world, MAV_CMD_DO_SET_MODE, 1, 6, 0) == MAV_RESULT_TEMPORARILY_REJECTED  # no offboard setpoints
    assert ack_of(world, MAV_CMD_DO_SET_MODE, 1, 4, 4) == MAV_RESULT_TEMPORARILY_REJECTED  # no mission
    assert ack_of(world, MAV_CMD_COMPONENT_ARM_DISARM, 0) == MAV_RESULT_ACCEPTED  # on the ground
    heartbeat = world.messages("HEARTBEAT")[-1]
    assert heartbeat.autopilot == 12 and heartbeat.type == 2 and heartbeat.base_mode & 32  # PX4, quad, HIL
    gps = world.messages("GPS_RAW_INT")[-1]
    assert gps.fix_type == 3 and abs(gps.lat - world.geodetic(0, 0)[0]) < 100
    assert world.messages("EXTENDED_SYS_STATE")[-1].landed_state == 1
    assert not math.isnan(world.messages("VFR_HUD")[-1].alt)


def test_two_ground_stations_are_each_answered(world):
    """QGroundControl (255/190) and MAVSDK (245/190) on the same link: each command's ACK and each transfer's
    messages are addressed to the system that asked; a second transfer while one runs is refused as PX4 does."""
    other = common.MAVLink(None, srcSystem=245, srcComponent=190)  # a second ground station on the same link
    world.run(0.5)
    world.link.transport.write(other.command_long_encode(1, 1, MAV_CMD_SET_MESSAGE_INTERVAL, 0, 33, 1e5, 0, 0, 0, 0,
                                                        0).pack(other))
    world.command(MAV_CMD_DO_CHANGE_SPEED, 1, 3, -1)
    world.run(0.1)
    acks = {(m.command, m.target_system) for m in world.messages("COMMAND_ACK")}
    assert {(MAV_CMD_SET_MESSAGE_INTERVAL, 245), (MAV_CMD_DO_CHANGE_SPEED, 255)} <= acks
    world.upload(waypoints(world, [(5, 0), (5, 5)]))
    world.send(world.gcs.mission_count_encode(1, 1, 2, 0))  # QGroundControl starts another upload...
    world.link.transport.write(other.mission_request_list_encode(1, 1, 0).pack(other))  # ...MAVSDK asks a list
    replies = world.pump(0.3)
    requests = [m for m in replies if m.get_type() in ("MISSION_REQUEST", "MISSION_REQUEST_INT")]
    assert requests and all(m.target_system == 255 for m in requests)
    assert "Mission download request ignored, already active" in world.texts()
