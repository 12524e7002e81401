"""The board session against a scripted PX4-like board over a real pty."""

from __future__ import annotations

import struct
import time

import numpy as np
import pytest
from pymavlink.dialects.v20.common import MAV_PARAM_TYPE_INT32, MAV_PARAM_TYPE_REAL32

from firmware_interface import hil_codec as codec
from firmware_interface.board import ON_OWN_CLOCK, SIMULATED, BoardError, BoardSession
from firmware_interface.board_waits import arm, set_offboard
from firmware_interface.board_watchdog import BOOT_US
from tests.support.scripted_board import ScriptedBoard

READINGS = codec.SensorReadings(0, (0.0, 0.0, -9.81), (0.0, 0.0, 0.0))
# floats, as the plant gives them: once a flight's warm-up froze the compiled packers (an earlier test in this
# process), tuples of ints would be an argument type they refuse
TRUTH = codec.GroundTruth(0, (1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 47.4, 8.5, 488.0, (0.0, 0.0, 0.0),
                          (0.0, 0.0, -9.81))


@pytest.fixture
def board():
    scripted = ScriptedBoard()
    yield scripted
    scripted.stop()


def test_handshake_reports_what_the_board_is(board):
    session = BoardSession(board.start(), SIMULATED)
    info = session.wait_heartbeat(2.0)
    assert (info.autopilot, info.vehicle_type, info.hil_enabled, info.armed) == (12, 2, True, False)
    for _ in range(40):
        if "HEARTBEAT" in board.received:
            break
        session.poll(0.05)
    assert "HEARTBEAT" in board.received  # we announce ourselves too (PX4 USB needs it)


def test_no_heartbeat_gives_the_actionable_message():
    scripted = ScriptedBoard(send_heartbeat=False)
    session = BoardSession(scripted.start(), ON_OWN_CLOCK)
    with pytest.raises(BoardError, match=r"no heartbeat on .* within 0.3 s \(no bytes arrived at all\) "
                                         r"— is SYS_HITL=1 set"):
        session.wait_heartbeat(0.3)
    scripted.stop()


def test_lockstep_free_runs_then_one_sensor_step_per_actuator_message(board):
    session = BoardSession(board.start(), SIMULATED, watchdog_s=2.0)
    session.wait_heartbeat(2.0)
    steps_before_lockstep = 0
    while not session.lockstep:
        session.exchange(codec.SensorReadings(steps_before_lockstep * 4000, (0, 0, -9.81), (0, 0, 0)))
        steps_before_lockstep += 1
        assert steps_before_lockstep < 2000
    assert steps_before_lockstep > board.free_run  # free-ran without waiting
    for k in range(50):
        out = session.exchange(codec.SensorReadings(10_000_000 + k * 4000, (0, 0, -9.81), (0, 0, 0)))
        assert out is not None and out.t_us == 10_000_000 + k * 4000  # the reply to this very step


def test_a_reply_that_starts_lockstep_during_a_free_run_wait_makes_the_step_wait_for_its_own():
    """The first reply comes a step late, while the bench waits, free-running, for the next step's; that step's
    own reply comes after the free-run wait but well within the watchdog. From the first lockstep reply on the
    board answers every step, so the step is waited for: not a lockstep failure after the free-run wait (seen
    with a loaded machine's emulator: "no HIL_ACTUATOR_CONTROLS within 10.00 s" ten milliseconds into a wait)."""
    scripted = ScriptedBoard(free_run=0, lag_first_answers_s=0.4)
    session = BoardSession(scripted.start(), SIMULATED, watchdog_s=2.0, free_run_wait_s=0.2)
    session.wait_heartbeat(2.0)
    first = session.exchange(codec.SensorReadings(4000, (0, 0, -9.81), (0, 0, 0)))
    assert first is None and not session.lockstep  # free-run: the held reply was not waited for past 0.2 s
    began = time.monotonic()
    second = session.exchange(codec.SensorReadings(8000, (0, 0, -9.81), (0, 0, 0)))
    assert session.lockstep and second is not None and second.t_us == 8000  # its own reply, not the first's
    assert time.monotonic() - began >= 0.4  # it came 0.4 s after the first's: past the free-run wait, waited for
    third = session.exchange(codec.SensorReadings(12000, (0, 0, -9.81), (0, 0, 0)))
    assert third is not None and third.t_us == 12000
    scripted.stop()


def test_arm_is_acknowledged_and_a_refusal_is_an_error(board):
    session = BoardSession(board.start(), SIMULATED)
    session.wait_heartbeat(2.0)
    arm(session, True, timeout_s=2.0)
    assert board.armed
    board.accept_arm = False
    with pytest.raises(BoardError, match=r"arming refused \(MAV_RESULT 4\)"):
        arm(session, True, timeout_s=2.0)


def test_setpoints_and_offboard_reach_the_board(board):
    session = BoardSession(board.start(), SIMULATED)
    session.wait_heartbeat(2.0)
    session.send_setpoint(100, (1.0, 2.0, -3.0), (0.1, -0.2, 0.3), (0.0, 0.5, 0.0), 0.5)
    set_offboard(session, timeout_s=2.0)
    target = board.messages["SET_POSITION_TARGET_LOCAL_NED"]
    # MAVLink common.xml: MAV_FRAME_LOCAL_NED = 1; POSITION_TARGET_TYPEMASK bit 11 (2048) ignores the yaw
    # rate, every other field (position, velocity, acceleration, yaw) is used
    assert (target.time_boot_ms, target.coordinate_frame, target.type_mask) == (100, 1, 2048)
    assert (target.x, target.y, target.z, target.yaw) == pytest.approx((1.0, 2.0, -3.0, 0.5))
    assert (target.vx, target.vy, target.vz, target.afx, target.afy, target.afz) == pytest.approx(
        (0.1, -0.2, 0.3, 0.0, 0.5, 0.0))
    mode = board.messages["COMMAND_LONG"]
    # MAV_CMD_DO_SET_MODE (176): param1 MAV_MODE_FLAG_CUSTOM_MODE_ENABLED (1), param2 PX4's main mode OFFBOARD (6)
    assert (mode.command, mode.param1, mode.param2) == (176, 1.0, 6.0)


def test_ground_truth_never_goes_to_a_real_board():
    scripted = ScriptedBoard()
    session = BoardSession(scripted.start(), ON_OWN_CLOCK)
    session.wait_heartbeat(2.0)
    for _ in range(20):
        session.exchange(READINGS, truth=TRUTH)
        session.send_ground_truth_ahead(TRUTH.t_us, *(np.array(v) for v in (
            TRUTH.q_wxyz, TRUTH.rates_frd, (TRUTH.lat_deg, TRUTH.lon_deg, TRUTH.alt_msl_m), TRUTH.vel_ned,
            TRUTH.specific_force_frd)), TRUTH.airspeed_m_s)
    session.poll(0.2)
    assert "HIL_SENSOR" in scripted.received
    assert "HIL_STATE_QUATERNION" not in scripted.received
    scripted.stop()
    emulator = ScriptedBoard()
    session = BoardSession(emulator.start(), SIMULATED)
    session.wait_heartbeat(2.0)
    session.exchange(READINGS, truth=TRUTH)
    session.poll(0.2)
    assert "HIL_STATE_QUATERNION" in emulator.received
    emulator.stop()


def test_a_board_silent_while_it_boots_is_reported_after_its_start_timeout_not_the_watchdog():
    scripted = ScriptedBoard(answer_sensors=False)
    session = BoardSession(scripted.start(), SIMULATED, watchdog_s=0.2)
    began = time.monotonic()  # before the heartbeat the silence is counted from
    session.wait_heartbeat(0.6)  # the start timeout: also the silence allowed until the board has booted
    scripted.send_heartbeat = False
    with pytest.raises(BoardError, match=r"board silent for .* while it boots \(allowed 0.6 s, its start timeout"):
        for _ in range(1000):
            session.exchange(READINGS)
    assert time.monotonic() - began >= 0.6
    scripted.stop()


def test_once_its_replies_span_the_boot_a_silent_board_is_reported_after_the_watchdog(board):
    session = BoardSession(board.start(), SIMULATED, watchdog_s=0.2)
    session.wait_heartbeat(5.0)
    board.send_heartbeat = False
    step_us, t_us = 50_000, 0
    while session.watchdog.booting:
        t_us += step_us
        session.exchange(codec.SensorReadings(t_us, (0, 0, -9.81), (0, 0, 0)))
        assert t_us < 10_000_000
    first_reply_us = (board.free_run + 1) * step_us  # the board free-runs its first steps unanswered
    assert t_us == first_reply_us + BOOT_US  # booted with the reply BOOT_US of simulated time past the first
    board.answer_sensors = False
    began = time.monotonic()
    with pytest.raises(BoardError, match=r"board silent for .* \(watchdog 0.20 s\)"):
        session.exchange(codec.SensorReadings(t_us + step_us, (0, 0, -9.81), (0, 0, 0)))
    assert time.monotonic() - began < 5.0  # the watchdog's 0.2 s, not the start timeout's 5 s


def test_an_int_parameter_goes_as_int32_with_its_own_bytes_and_comes_back_as_its_value(board):
    """MAVLink's bytewise parameter encoding, which PX4 uses (it refuses a PARAM_SET whose type is not the
    parameter's, and copies the float field's four bytes into an INT32 one): the bytes of the float field are
    those of the integer, little-endian, and PARAM_VALUE's are read back the same way."""
    session = BoardSession(board.start(), SIMULATED)
    session.wait_heartbeat(2.0)
    session.set_param("CA_ROTOR_COUNT", 6)
    session.set_param("EKF2_GPS_DELAY", 120.0)
    for _ in range(40):
        if {"CA_ROTOR_COUNT", "EKF2_GPS_DELAY"} <= set(session.report.params):
            break
        session.poll(0.05)
    wire, kind = board.params["CA_ROTOR_COUNT"]
    assert kind == MAV_PARAM_TYPE_INT32 and struct.pack("<f", wire) == (6).to_bytes(4, "little")
    assert board.params["EKF2_GPS_DELAY"] == (120.0, MAV_PARAM_TYPE_REAL32)
    assert session.report.params == {"CA_ROTOR_COUNT": 6.0, "EKF2_GPS_DELAY": 120.0}
