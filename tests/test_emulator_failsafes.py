"""The emulator's stick flight and failsafes against PX4 v1.15.4's own rules (commander failsafe framework,
parameters and texts), flown in the test world (real plant FMU, real pty, a pymavlink ground station): each
trigger, then the mode change within the time the parameters imply, read from the board's STATUSTEXT and
HEARTBEAT and from the plant's true state."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pymavlink.dialects.v20.common import (
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_CMD_DO_REPOSITION,
    MAV_CMD_NAV_TAKEOFF,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_TEMPORARILY_REJECTED,
)

from firmware_interface.emulator.manual_control import expo_deadzone
from tests.support.emulator_world import World

pytestmark = [pytest.mark.e2e, pytest.mark.slow]
NAN = float("nan")
SETTLE_S = 4.0
TICK_S = 0.05  # the emulator's commander and navigator decide at 20 Hz
AUTO_LOITER, AUTO_RTL, AUTO_LAND, POSCTL = 0x0304_0000, 0x0504_0000, 0x0604_0000, 0x0003_0000
CENTRED = (0, 0, 500, 0)


def text_time(world: World, text: str, after_us: int = 0) -> float:
    """Simulated seconds at which the board sent `text` (first time after `after_us`)."""
    return next(t for t, m in world.received if t > after_us and m.get_type() == "STATUSTEXT" and m.text == text) * 1e-6


def mode(world: World) -> int:
    return world.latest["HEARTBEAT"].custom_mode


def ack(world: World, command: int, *params: float) -> int:
    world.command(command, *params)
    world.run(0.1)
    return next(m.result for m in reversed(world.messages("COMMAND_ACK")) if m.command == command)


def take_off(world: World) -> None:
    world.command(MAV_CMD_NAV_TAKEOFF, 0, 0, 0, NAN, NAN, NAN, NAN)
    world.command(MAV_CMD_COMPONENT_ARM_DISARM, 1)
    world.run_until(lambda: mode(world) == AUTO_LOITER, 15)
    world.run(3.0)


def test_stick_expo_is_px4s():
    """math::expo_deadzone with MPC_HOLD_DZ 0.1 and the expos' 0.6: x = (0.5 − 0.1)/0.9 = 0.444,
    0.4·x + 0.6·x³ = 0.2305; inside the deadzone 0; full stick 1."""
    assert expo_deadzone(0.5, 0.6, 0.1) == pytest.approx(0.4 * 4 / 9 + 0.6 * (4 / 9) ** 3)
    assert expo_deadzone(-0.5, 0.6, 0.1) == pytest.approx(-0.2305, abs=1e-4)
    assert expo_deadzone(0.09, 0.6, 0.1) == 0.0 and expo_deadzone(1.2, 0.6, 0.1) == 1.0


def test_sticks_fly_position_control_and_centred_sticks_hold(tmp_path):
    """MANUAL_CONTROL as QGroundControl's joystick sends it (20 Hz). Half throttle up (z = 750: throttle 0.5) asks
    0.2305 · MPC_Z_VEL_MAX_UP 3 = 0.69 m/s up; half pitch forward (x = 500) 0.2305 · MPC_VEL_MANUAL 10 = 2.3 m/s
    north (heading 0); half yaw 0.2305 · MPC_MAN_Y_MAX 150 = 34.6 °/s. Centred sticks hold position."""
    world = World(tmp_path)
    try:
        world.sticks = (0, 0, 800, 0)  # throttle 0.6, above PX4's 0.2
        world.run(SETTLE_S)
        assert ack(world, MAV_CMD_COMPONENT_ARM_DISARM, 1) == MAV_RESULT_TEMPORARILY_REJECTED
        assert "Arming denied: throttle above center" in world.texts()
        world.sticks = CENTRED
        world.run(0.1)
        assert ack(world, MAV_CMD_COMPONENT_ARM_DISARM, 1) == MAV_RESULT_ACCEPTED
        world.sticks = (0, 0, 750, 0)
        world.run(4.0)
        climb = [-p[2] for _, p in world.truth[-250:]]
        assert (climb[-1] - climb[0]) == pytest.approx(0.69, rel=0.15)  # m in the last second
        world.sticks = CENTRED
        world.run(3.0)
        height = world.height_m()
        world.run(2.0)
        assert abs(world.height_m() - height) < 0.1
        world.sticks = (500, 0, 500, 0)
        world.run(3.0)
        start = world.state.pos_ned.copy()
        world.run(3.0)
        travelled = world.state.pos_ned - start
        assert travelled[0] / 3.0 == pytest.approx(2.305, rel=0.15) and abs(travelled[1]) < 0.5
        world.sticks = CENTRED
        world.run(3.0)  # braking at MPC_ACC_HOR_MAX 5 m/s² and the controller settling
        held = world.state.pos_ned.copy()
        world.run(3.0)
        assert float(np.linalg.norm(world.state.pos_ned - held)) < 0.3
        world.sticks = (0, 0, 500, 500)
        world.run(1.0)
        yaw0 = world.attitudes[-1][2]
        world.run(1.0)
        assert math.degrees(math.remainder(world.attitudes[-1][2] - yaw0, math.tau)) == pytest.approx(34.6, rel=0.15)
        assert mode(world) == POSCTL
    finally:
        world.close()


def test_manual_control_loss_holds_com_fail_act_t_then_returns(tmp_path):
    """Sticks stop: after COM_RC_LOSS_T (0.5 s) NAV_RCL_ACT 2 (return), first holding COM_FAIL_ACT_T (5 s); the
    return lands at home and disarms."""
    world = World(tmp_path)
    try:
        world.sticks = CENTRED
        world.run(SETTLE_S)
        world.command(MAV_CMD_COMPONENT_ARM_DISARM, 1)
        world.sticks = (0, 0, 1000, 0)  # full throttle: 3 m/s up
        world.run(1.5)
        world.sticks = CENTRED
        world.run(2.0)
        last_stick_us = world.t_us - world.t_us % 50_000
        world.sticks = None
        world.run_until(lambda: mode(world) == AUTO_LOITER, 2.0)
        held = text_time(world, "Failsafe activated: entering Hold for 5 seconds", last_stick_us)
        assert 0.5 < held - last_stick_us * 1e-6 <= 0.5 + TICK_S + 0.004
        world.run_until(lambda: mode(world) == AUTO_RTL, 7.0)
        returned = text_time(world, "Failsafe activated", int(held * 1e6))
        assert returned - held == pytest.approx(5.0, abs=TICK_S + 0.004)
        world.run_until(lambda: not world.armed, 30)
        assert world.state.on_ground and math.hypot(*world.state.pos_ned[:2]) < 1.0
    finally:
        world.close()


def test_data_link_loss_lands_as_nav_dll_act_says(tmp_path):
    """No GCS heartbeat for COM_DL_LOSS_T (5 s here; PX4's minimum): "Connection to ground station lost", then
    NAV_DLL_ACT 3 (land) after the COM_FAIL_ACT_T hold (2 s here). The heartbeats back: "GCS connection regained"."""
    world = World(tmp_path, {"NAV_DLL_ACT": 3, "COM_DL_LOSS_T": 5, "COM_FAIL_ACT_T": 2})
    try:
        world.run(SETTLE_S)
        take_off(world)
        world.gcs_heartbeats = False
        last_heartbeat_s = (world.t_us - world.t_us % 1_000_000 + 4000) * 1e-6
        world.run_until(lambda: mode(world) == AUTO_LAND, 12)
        lost = text_time(world, "Connection to ground station lost")
        assert 5.0 < lost - last_heartbeat_s <= 5.0 + TICK_S + 0.004
        held = text_time(world, "Failsafe activated: entering Hold for 2 seconds")
        landing = text_time(world, "Failsafe activated", int(held * 1e6))
        assert held == pytest.approx(lost, abs=TICK_S + 0.004) and landing - held == pytest.approx(2.0, abs=0.06)
        world.run_until(lambda: not world.armed, 15)
        world.run(1.1)
        assert world.state.on_ground and mode(world) == POSCTL
        world.gcs_heartbeats = True
        world.run(1.1)
        assert "GCS connection regained" in world.texts()
    finally:
        world.close()


def test_battery_warns_at_low_returns_at_critical_lands_at_emergency(tmp_path):
    """BATTERY_STATUS from the vehicle's battery component (id 180). COM_LOW_BAT_ACT 3: below BAT_LOW_THR (15 %) a
    warning only; below BAT_CRIT_THR (7 %) return after the COM_FAIL_ACT_T hold; below BAT_EMERGEN_THR (5 %) land at
    once. Armed, the warning never falls back; critical refuses arming. The autopilot's own id is ignored."""
    world = World(tmp_path, {"COM_LOW_BAT_ACT": 3, "COM_FAIL_ACT_T": 2})
    try:
        world.battery_percent = 6
        world.run(SETTLE_S)
        assert ack(world, MAV_CMD_COMPONENT_ARM_DISARM, 1) == MAV_RESULT_TEMPORARILY_REJECTED
        world.battery_percent = 50
        world.run(2.1)  # disarmed, the warning follows the battery back
        assert world.messages("SYS_STATUS")[-1].battery_remaining == 50
        take_off(world)
        lat, lon = world.geodetic(8.0, 0.0)
        world.command(MAV_CMD_DO_REPOSITION, -1, 1, 0, NAN, lat * 1e-7, lon * 1e-7, NAN)
        world.run(5.0)
        world.battery_percent = 14
        world.run(1.1)
        assert mode(world) == AUTO_LOITER and world.texts()[-2:] == ["Low battery level", "Failsafe activated"]
        world.battery_percent = 6
        world.run_until(lambda: mode(world) == AUTO_RTL, 5)
        held = text_time(world, "Failsafe activated: entering Hold for 2 seconds")
        assert text_time(world, "Failsafe activated", int(held * 1e6)) - held == pytest.approx(2.0, abs=0.06)
        world.battery_percent = 50
        world.run(1.5)
        assert mode(world) == AUTO_RTL  # armed, a warning does not fall back
        world.battery_percent = 4
        world.run_until(lambda: mode(world) == AUTO_LAND, 3)
        emergency = max(t for t, m in world.received if m.get_type() == "STATUSTEXT" and m.text == "Low battery level")
        assert text_time(world, "Failsafe activated", emergency) - emergency * 1e-6 <= TICK_S + 0.004
        world.run_until(lambda: not world.armed, 20)
        assert world.state.on_ground
    finally:
        world.close()


def test_gps_loss_descends_blind_and_lands(tmp_path):
    """HIL_GPS stops: after EKF2_NOAID_TOUT (5 s) the position estimate is invalid, so AUTO.LOITER cannot run; the
    return and the land mode need a position too, so PX4 descends blind (nav state DESCEND, custom mode
    AUTO.LAND) at MPC_LAND_SPEED, level, and the land detector disarms it."""
    world = World(tmp_path)
    try:
        world.run(SETTLE_S)
        take_off(world)
        world.gps_on = False
        lost_at = world.state.pos_ned.copy()
        world.run_until(lambda: mode(world) == AUTO_LAND, 8)
        failsafe = text_time(world, "Failsafe activated")
        assert 5.0 < failsafe - world.last_gps_us * 1e-6 <= 5.0 + TICK_S + 0.004
        assert world.latest["HEARTBEAT"].system_status == 5  # MAV_STATE_CRITICAL
        world.run_until(lambda: not world.armed, 15)
        assert world.state.on_ground
        assert math.hypot(*(world.state.pos_ned[:2] - lost_at[:2])) < 2.0  # level: drifts only with the estimate
    finally:
        world.close()
