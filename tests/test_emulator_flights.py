"""The emulator flown by a ground station as PX4's own integration tests fly PX4 (test/mavsdk_tests in PX4 v1.15.4:
"Takeoff and Land", "Fly square Multicopter Missions including RTL", "Offboard position control"), in a world of
the real plant FMU in lockstep over a real pty. Every result is read from the plant's true state."""

from __future__ import annotations

import math
from itertools import pairwise

import numpy as np
import pytest
from pymavlink.dialects.v20.common import (
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_CMD_DO_SET_MODE,
    MAV_CMD_MISSION_START,
    MAV_CMD_NAV_LAND,
    MAV_CMD_NAV_RETURN_TO_LAUNCH,
    MAV_CMD_NAV_TAKEOFF,
    MAV_CMD_NAV_WAYPOINT,
    MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
    MAV_FRAME_LOCAL_NED,
    MAV_FRAME_MISSION,
)

from tests.support.emulator_world import World

pytestmark = [pytest.mark.e2e, pytest.mark.slow]
NAN = float("nan")
SETTLE_S = 4.0
AUTO_LOITER, AUTO_RTL, OFFBOARD, POSCTL = 0x0304_0000, 0x0504_0000, 0x0006_0000, 0x0003_0000
POSITION_ONLY = 0b1001_1111_1000  # MAVSDK's set_position_ned: velocity, acceleration, yaw rate ignored
VELOCITY_ONLY = 0b1001_1100_0111  # MAVSDK's set_velocity_ned


def mode(world: World) -> int:
    return world.latest["HEARTBEAT"].custom_mode


def test_takeoff_to_mis_takeoff_alt_and_land(tmp_path):
    """NAV_TAKEOFF with no altitude climbs MIS_TAKEOFF_ALT (PX4's default 2.5 m) above the vehicle, then holds in
    AUTO.LOITER; NAV_LAND lands, the land detector fires, and COM_DISARM_LAND (2 s) later the board disarms."""
    world = World(tmp_path)
    try:
        world.run(SETTLE_S)
        world.command(MAV_CMD_NAV_TAKEOFF, 0, 0, 0, NAN, NAN, NAN, NAN)
        world.command(MAV_CMD_COMPONENT_ARM_DISARM, 1)
        world.run_until(lambda: mode(world) == AUTO_LOITER, 15)  # the climb is done within NAV_MC_ALT_RAD
        world.run(5.0)  # and ends at rest at the take-off altitude; hovering there, the height holds
        heights = [-float(p[2]) for _, p in world.truth[-500:]]
        assert min(heights) >= 2.25 and max(heights) <= 2.75  # MIS_TAKEOFF_ALT ± 10 %
        assert abs(np.mean(heights) - 2.5) < 0.1
        world.command(MAV_CMD_NAV_LAND)
        landing_s = world.run_until(lambda: not world.armed, 20)
        # 2.5 m at MPC_LAND_SPEED 0.7 m/s, the detector's 1 s and COM_DISARM_LAND's 2 s: ~6.6 s
        assert 5.5 < landing_s < 9.0
        assert world.state.on_ground and math.hypot(*world.state.pos_ned[:2]) < 0.5
        assert "Using default takeoff altitude: 2.5 m" in world.texts() and "Disarmed by landing" in world.texts()
    finally:
        world.close()


def square_mission(world: World, leg_m: float, altitude: float) -> list:
    """PX4's prepare_square_mission (leg, leg), (leg, 0)... as its square's three corners plus home, then
    RETURN_TO_LAUNCH as MAVSDK appends it (MAV_FRAME_MISSION)."""
    corners = [(leg_m, 0.0), (leg_m, leg_m), (0.0, leg_m), (0.0, 0.0)]
    items = []
    for seq, (north, east) in enumerate(corners):
        lat, lon = world.geodetic(north, east)
        items.append(world.gcs.mission_item_int_encode(1, 1, seq, MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                                                        MAV_CMD_NAV_WAYPOINT, 0, 1, 0, 0, 0, NAN, lat, lon, altitude,
                                                        0))
    items.append(world.gcs.mission_item_int_encode(1, 1, len(items), MAV_FRAME_MISSION, MAV_CMD_NAV_RETURN_TO_LAUNCH,
                                                   0, 1, 0, 0, 0, 0, 0, 0, 0, 0))
    return items


def distance_to_legs(point: np.ndarray, corners: list[np.ndarray]) -> float:
    """Horizontal distance from a point to the polyline through the corners."""
    best = math.inf
    for a, b in pairwise(corners):
        ab, ap = b - a, point - a
        t = min(max(float(ab @ ap) / float(ab @ ab), 0.0), 1.0) if float(ab @ ab) > 0 else 0.0
        best = min(best, float(np.linalg.norm(ap - t * ab)))
    return best


def test_square_mission_then_rtl_lands_at_home(tmp_path):
    """Four waypoints 10 m apart at 5 m and RTL: every MISSION_ITEM_REACHED in order, never outside a 5 m corridor
    around the legs, back within 2 m of home, disarmed. RTL_RETURN_ALT/RTL_DESCEND_ALT are lowered (as a user
    would for a small field) so that the return needs no 30 m climb."""
    world = World(tmp_path, {"RTL_RETURN_ALT": 5.0, "RTL_DESCEND_ALT": 3.0})
    try:
        world.run(1.0)
        _, ack = world.upload(square_mission(world, 10.0, 5.0))
        assert ack is not None and ack.type == 0
        world.run(SETTLE_S - 1.0)
        world.command(MAV_CMD_MISSION_START, 0, 0)
        flown = world.run_until(lambda: not world.armed and world.t_us > 6e6, 90)
        reached = [m.seq for m in world.messages("MISSION_ITEM_REACHED")]
        assert [seq for i, seq in enumerate(reached) if i == 0 or seq != reached[i - 1]] == [0, 1, 2, 3]
        assert AUTO_RTL in {m.custom_mode for m in world.messages("HEARTBEAT")}
        corners = [np.array(c) for c in ((0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0), (0.0, 0.0))]
        airborne = [p for _, p in world.truth if p[2] < -1.0]
        assert max(distance_to_legs(p[:2], corners) for p in airborne) < 5.0
        assert max(-p[2] for p in airborne) < 5.5
        assert math.hypot(*world.state.pos_ned[:2]) < 2.0 and world.state.on_ground
        assert flown < 60
    finally:
        world.close()


def position_setpoint(world: World, north: float, east: float, down: float, yaw_deg: float) -> None:
    world.last_sent_us = world.t_us
    world.send(world.gcs.set_position_target_local_ned_encode(0, 1, 1, MAV_FRAME_LOCAL_NED, POSITION_ONLY, north,
                                                              east, down, 0, 0, 0, 0, 0, 0, math.radians(yaw_deg), 0))


def goto(world: World, target: tuple[float, float, float, float], radius_m: float, limit_s: float,
         yaw_within_deg: float | None = None) -> float:
    """offboard_goto: the setpoint streamed at 20 Hz (MAVSDK's rate) until the true position is within the radius
    (and, if asked, the true heading within `yaw_within_deg` of the setpoint's yaw)."""
    def close() -> bool:
        if world.t_us % 50_000 == 0:
            position_setpoint(world, *target)
        heading_off = abs(math.degrees(math.remainder(float(world.state.rpy[2]) - math.radians(target[3]), math.tau)))
        return float(np.linalg.norm(world.state.pos_ned - np.array(target[:3]))) < radius_m and (
            yaw_within_deg is None or heading_off < yaw_within_deg)
    return world.run_until(close, limit_s)


def test_offboard_position_setpoints_from_another_system(tmp_path):
    """PX4's "Offboard position control": from the ground, each position-only setpoint reached within 0.3 m within
    10 s, the heading turned to its yaw; then a 1 m/s velocity setpoint down lands and the board disarms,
    within 1 m of home."""
    world = World(tmp_path)
    try:
        world.run(SETTLE_S)
        world.command(MAV_CMD_COMPONENT_ARM_DISARM, 1)
        for _ in range(5):  # MAVSDK sends setpoints before offboard.start()
            position_setpoint(world, 0, 0, -2, 0)
            world.run(0.05)
        world.command(MAV_CMD_DO_SET_MODE, 1, 6, 0)
        for target in ((0, 0, -2, 0), (0, 5, -2, 180), (5, 5, -4, 180), (5, 0, -4, 90), (0, 0, -2, 0)):
            goto(world, target, 0.3, 10.0)
            assert mode(world) == OFFBOARD
        # the heading follows each setpoint's yaw at no more than MPC_YAWRAUTO_MAX (45°/s): it lags the position
        goto(world, (0, 0, -2, 0), 0.3, 8.0, yaw_within_deg=3.0)
        def down_1_m_s() -> bool:  # offboard_land: set_velocity_ned(0, 0, 1), streamed at 20 Hz
            if world.t_us % 50_000 == 0:
                world.send(world.gcs.set_position_target_local_ned_encode(0, 1, 1, MAV_FRAME_LOCAL_NED, VELOCITY_ONLY,
                                                                          0, 0, 0, 0, 0, 1.0, 0, 0, 0, 0, 0))
            return not world.armed
        world.run_until(down_1_m_s, 15)
        assert world.state.on_ground and math.hypot(*world.state.pos_ned[:2]) < 1.0
    finally:
        world.close()


def test_offboard_loss_holds_within_com_of_loss_t(tmp_path):
    """Setpoints stop: after COM_OF_LOSS_T (1 s) COM_OBL_RC_ACT 0 asks for position control, which without stick
    input cannot run, so PX4's failsafe falls through to Hold (framework.cpp): AUTO.LOITER, "Failsafe activated"."""
    world = World(tmp_path)
    try:
        world.run(SETTLE_S)
        world.command(MAV_CMD_COMPONENT_ARM_DISARM, 1)
        for _ in range(5):
            position_setpoint(world, 0, 0, -2, 0)
            world.run(0.05)
        world.command(MAV_CMD_DO_SET_MODE, 1, 6, 0)
        goto(world, (0, 0, -2, 0), 0.3, 10.0)
        last_setpoint_us = world.last_sent_us
        world.run_until(lambda: mode(world) == AUTO_LOITER, 3.0)
        failsafe_us = next(t for t, m in world.received if m.get_type() == "STATUSTEXT"
                           and m.text == "Failsafe activated")
        # COM_OF_LOSS_T after the last setpoint, at the next navigator tick (20 Hz)
        assert 1.0 < (failsafe_us - last_setpoint_us) * 1e-6 <= 1.0 + 0.05 + 0.004
        assert world.messages("HEARTBEAT")[-1].system_status == 5  # MAV_STATE_CRITICAL while the failsafe holds
        world.run(2.0)
        assert float(np.linalg.norm(world.state.pos_ned - np.array((0, 0, -2)))) < 0.5  # holds where it was
        world.command(MAV_CMD_NAV_RETURN_TO_LAUNCH)
        world.run_until(lambda: not world.armed, 25)
        assert world.state.on_ground and math.hypot(*world.state.pos_ned[:2]) < 1.0
    finally:
        world.close()


def test_land_command_is_accepted_while_landing_without_restarting(tmp_path):
    """A second NAV_LAND during a landing changes nothing (PX4: the same mode again is no transition)."""
    world = World(tmp_path)
    try:
        world.run(SETTLE_S)
        world.command(MAV_CMD_NAV_TAKEOFF, 0, 0, 0, NAN, NAN, NAN, NAN)
        world.command(MAV_CMD_COMPONENT_ARM_DISARM, 1)
        world.run_until(lambda: mode(world) == AUTO_LOITER, 15)
        world.command(MAV_CMD_NAV_LAND)
        world.run(1.5)
        height = world.height_m()
        world.command(MAV_CMD_NAV_LAND)
        world.run(1.0)
        assert world.height_m() < height - 0.5  # still going down at 0.7 m/s
        world.run_until(lambda: not world.armed, 10)
        assert mode(world) == POSCTL
    finally:
        world.close()


def test_land_commanded_at_cruise_speed_brakes_then_lands(tmp_path):
    """NAV_LAND halfway along a 40 m leg at MPC_XY_CRUISE (5 m/s): the vehicle brakes at MPC_ACC_HOR (3 m/s²; a
    smooth stop from 5 m/s covers 5·(2·5/3)/2 = 8.3 m) and lands there, without a hard tilt."""
    world = World(tmp_path)
    try:
        world.run(1.0)
        lat, lon = world.geodetic(40.0, 0.0)
        _, ack = world.upload([world.gcs.mission_item_int_encode(1, 1, 0, MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                                                                 MAV_CMD_NAV_WAYPOINT, 0, 1, 0, 0, 0, NAN, lat, lon,
                                                                 4.0, 0)])
        assert ack is not None and ack.type == 0
        world.run(SETTLE_S - 1.0)
        world.command(MAV_CMD_MISSION_START, 0, 0)
        world.run_until(lambda: world.state.pos_ned[0] > 15.0, 20)
        speed = float(np.linalg.norm(world.state.vel_ned[:2]))
        commanded_at = world.state.pos_ned.copy()
        world.command(MAV_CMD_NAV_LAND)
        start = len(world.truth)
        world.run_until(lambda: not world.armed, 20)
        assert speed > 3.0  # it was cruising
        travelled = float(np.linalg.norm(world.state.pos_ned[:2] - commanded_at[:2]))
        assert 0.5 * speed * (2 * speed / 3.0) / 2 < travelled < 8.3 + 1.5
        tilt = max(max(abs(rpy[0]), abs(rpy[1])) for rpy in world.attitudes[start:])
        assert tilt < math.radians(20)  # 3 m/s² of braking needs atan(3/9.81) = 17°
        assert world.state.on_ground
    finally:
        world.close()
