"""The failsafe inputs and their judge, in process: BATTERY_STATUS against the plant's battery in MAVLink's units
(common.xml) as PX4 v1.15.4 reads it back, MANUAL_CONTROL's sticks, the senders' rates and loss windows on the
bench's clock, the hover power the pack must give against our FMU, and the failsafe verdicts on hand-made flights."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from pymavlink.dialects.v20 import common

from firmware_interface.board import SIMULATED, BoardSession
from firmware_interface.hil_codec import SensorReadings
from firmware_interface.link import Link
from firmware_interface.link.transports import Transport
from firmware_interface.px4_modes import FlightMode
from firmware_interface.vehicle_codec import battery_status_fields, manual_control_fields
from hil.judge.failsafe import FailsafeJudge
from hil.judge.verdict import Moment
from hil.loop.frame import StepFrame
from hil.loop.senders import Senders, senders_for
from hil.scenario.environment import EnvironmentSample
from hil.scenario.failsafe import FailsafeExpected
from hil.scenario.schema import Scenario
from hil.scenario.vehicles import cell_open_circuit_v, hover_power_w, plant_parameters
from plant_fmu import Plant
from plant_fmu.state import BatteryState

UINT16_MAX = 65535
STEP_US = 4000  # 250 Hz


class Wire(Transport):
    """The bytes a link writes, kept for a pymavlink parser (no board: only what leaves the bench is checked)."""

    name = "wire"

    def __init__(self) -> None:
        self.written = bytearray()

    def write(self, data: bytes) -> None:
        self.written += data

    def read(self, timeout_s: float) -> bytes:
        return b""

    def close(self) -> None:
        pass


def sent(wire: Wire) -> list[common.MAVLink_message]:
    parser = common.MAVLink(None)
    return list(parser.parse_buffer(bytes(wire.written)) or [])


@pytest.fixture(scope="module")
def hovering() -> BatteryState:
    """Our FMU's 4S 2 A·h pack after 3 s of a hover at the hover command (the plant's own thrust curve)."""
    params = {**plant_parameters("inspection_quad", {}), "battery_capacity": 2.0, "init_pos_d": -10.0}
    k, t_max, g, mass = params["thrust_curve_k"], params["thrust_max"], 9.80665, params["mass"]
    thrust = mass * g / 4
    u = (-(1 - k) + math.sqrt((1 - k) ** 2 + 4 * k * thrust / t_max)) / (2 * k)
    with Plant(params) as plant:
        zero = np.zeros(3)
        for _ in range(750):
            plant.set_input_groups((u,) * 4, (1.0,) * 4, zero, zero, zero, 0.0)
            plant.step(0.004)
        state = plant.state()
        assert state.battery is not None
        return state.battery


def test_battery_status_carries_the_plants_pack_in_mavlinks_units(hovering):
    """common.xml: voltages in mV (UINT16_MAX past the cells), current in cA, consumed in mAh, remaining in %;
    sent by component 180 of the vehicle's own system, which is what PX4 takes (mavlink_receiver.cpp: another
    system's, or the autopilot's own, is ignored). PX4 sums the cells up to the first UINT16_MAX."""
    wire = Wire()
    session = BoardSession(Link(wire), SIMULATED)
    session.link.encoder.system_id = 1  # adopted from the board's heartbeat
    senders = Senders(battery=senders_for(Scenario(name="b", battery={"capacity_ah": 2.0}), True).battery, cells=4)
    senders.send(session, STEP_US, -math.inf, _state(hovering), lambda text: None)
    (message,) = sent(wire)
    assert message.get_type() == "BATTERY_STATUS"
    assert (message.get_srcSystem(), message.get_srcComponent()) == (1, common.MAV_COMP_ID_BATTERY)
    cells = hovering.cell_voltages_v[:4]
    assert list(message.voltages) == [round(v * 1000) for v in cells] + [UINT16_MAX] * 6
    assert list(message.voltages_ext) == [0, 0, 0, 0]
    px4_voltage_v = sum(v for v in message.voltages if v < UINT16_MAX) / 1000
    assert px4_voltage_v == pytest.approx(hovering.voltage_v, abs=4 * 0.0005)  # each cell rounded to a mV
    assert message.current_battery == round(hovering.current_a * 100) and 900 < message.current_battery < 1500
    assert message.current_consumed == round(hovering.consumed_c / 3.6) > 0  # mAh = C / 3.6
    assert message.battery_remaining == round(hovering.remaining * 100)
    assert message.type == common.MAV_BATTERY_TYPE_LIPO and message.temperature == 0x7FFF


def _state(battery: BatteryState):
    with Plant({}) as plant:
        return dataclasses.replace(plant.state(), battery=battery)


def test_a_pack_without_cell_voltages_goes_in_cell_one_and_its_excess_in_cell_two():
    """common.xml: the pack's voltage in voltages[0] when the cells are not known; above 65534 mV, the rest in
    voltages[1]; the other cells UINT16_MAX."""
    fields = battery_status_fields(70.0, 5.0, 36.0, 0.5, [])
    assert fields["voltages"] == [65534, 70000 - 65534] + [UINT16_MAX] * 8
    assert battery_status_fields(12.6, 5.0, 36.0, 0.5, [])["voltages"][:2] == [12600, UINT16_MAX]
    assert fields["current_consumed"] == 10 and fields["battery_remaining"] == 50  # 36 C = 10 mAh


@pytest.mark.parametrize(("sticks", "xyzr"), [
    ((0.0, 0.0, 0.0, 0.0), (0, 0, 500, 0)),
    ((0.5, -0.25, 1.0, -1.0), (500, -250, 1000, -1000)),
    ((-1.0, 1.0, -1.0, 0.3), (-1000, 1000, 0, 300)),
])
def test_manual_control_is_what_px4_reads_back_as_the_sticks(sticks, xyzr):
    """PX4 (mavlink_receiver.cpp): pitch = x / 1000, roll = y / 1000, throttle = z / 1000 · 2 − 1, yaw = r / 1000."""
    fields = manual_control_fields(1, *sticks)
    assert (fields["x"], fields["y"], fields["z"], fields["r"]) == xyzr
    assert fields["z"] / 1000 * 2 - 1 == pytest.approx(sticks[2])


def test_the_senders_keep_their_rates_and_stop_in_their_windows():
    """10 s at 250 Hz: BATTERY_STATUS at 2 Hz, MANUAL_CONTROL at 25 Hz, from the first step; in the joystick's loss
    (4-5 s) no sticks; in the ground station's loss (7 s on) no sticks and no bench heartbeat, the battery going
    on."""
    scenario = Scenario(name="s", duration_s=10, battery={}, manual_control={"pitch": "0.5*sin(t)",
                                                                               "loss": [{"start_s": 4, "end_s": 5}]},
                        faults={"ground_station": [{"start_s": 7}]})
    senders = senders_for(scenario, True)
    wire = Wire()
    session = BoardSession(Link(wire), SIMULATED)
    notes: list[str] = []
    with Plant({}) as plant:
        truth = plant.state()
        for step in range(1, 2501):
            t_us = step * STEP_US
            session.ground_station_silent = senders.ground_station_lost(t_us * 1e-6)
            session.service(t_us * 1e-6)
            senders.send(session, t_us, t_us * 1e-6, truth, notes.append)
    messages = sent(wire)
    kinds = [m.get_type() for m in messages]
    assert kinds.count("BATTERY_STATUS") == 1 + 20  # the first step's, then every 0.5 s to 10 s
    sticks = [m for m in messages if m.get_type() == "MANUAL_CONTROL"]
    assert len(sticks) == 1 + 250 - 25 - 76  # every 40 ms but in [4, 5) s and [7, 10] s
    assert kinds.count("HEARTBEAT") == 7  # 1 Hz until the ground station is lost at 7 s
    assert notes == ["joystick lost: no MANUAL_CONTROL", "joystick back",
                     "ground station lost: its heartbeats, commands, joystick and relayed traffic stop",
                     "joystick lost: no MANUAL_CONTROL"]
    assert max(abs(m.x) for m in sticks) <= 500  # 0.5 sin(t): within half a stick


def test_the_hover_power_closed_form_is_what_our_fmu_draws():
    """hover_power_w (n·k_m·T·w/efficiency, T = m·g/n) against the FMU's own V·I hovering, and the open-circuit
    curve at full charge against its 4.10 V."""
    params = plant_parameters("inspection_quad", {})
    with Plant({**params, "init_pos_d": -10.0}) as plant:
        k, t_max, thrust = params["thrust_curve_k"], params["thrust_max"], params["mass"] * 9.80665 / 4
        u = (-(1 - k) + math.sqrt((1 - k) ** 2 + 4 * k * thrust / t_max)) / (2 * k)
        zero = np.zeros(3)
        for _ in range(1500):
            plant.set_input_groups((u,) * 4, (1.0,) * 4, zero, zero, zero, 0.0)
            plant.step(0.004)
        battery = plant.state().battery
    assert battery is not None
    assert battery.voltage_v * battery.current_a == pytest.approx(hover_power_w(params, 4), rel=0.01)
    assert cell_open_circuit_v(1.0) == pytest.approx(4.10, abs=0.005)


# --- the judge on hand-made flights -----------------------------------------------------------------
def frame(truth, t_s: float, armed: bool, board=(), sent=()) -> StepFrame:
    zero = np.zeros(3)
    return StepFrame(round(t_s * 1e6) + 5_000_000, t_s, "mission", truth, None, SensorReadings(round(t_s * 1e6)),
                     None, (0.0,) * 4, armed, EnvironmentSample(zero, zero, zero, 0.0, (1.0,) * 4),
                     board=list(board), sent=list(sent))


def beat(mode: FlightMode, critical: bool = False) -> tuple[str, dict]:
    return "HEARTBEAT", {"armed": True, "custom_mode": int(mode), "system_status": 5 if critical else 4}


@pytest.fixture(scope="module")
def resting():
    with Plant({}) as plant:
        return plant.state()


def battery_flight(judge: FailsafeJudge, resting, modes: list[tuple[float, FlightMode]], land_at: float,
                   seconds: float = 40.0) -> None:
    """Charge sent every 0.5 s falling 1 % a second from 14.3 %; the board's modes at their times (critical in all
    but the mission); disarmed at `land_at`, 1 m from home."""
    for step in range(round(seconds * 10)):
        t = step * 0.1
        sent = [("battery", {"remaining": 0.143 - 0.01 * t})] if step % 5 == 0 else []
        board = [beat(mode, mode is not FlightMode.AUTO_MISSION) for at, mode in modes if abs(at - t) < 1e-9]
        truth = dataclasses.replace(resting, pos_ned=np.array((0.6, 0.8, 0.0 if t >= land_at else -5.0)))
        judge.on_step(frame(truth, t, t < land_at, board, sent))


def test_a_return_after_the_hold_is_the_reaction_and_landing_at_home_is_judged(resting):
    """Sent below BAT_CRIT_THR 7 % first at t = 8 s (6.3 %: 6 %; at 7.5 s 6.8 % is sent as 7 %, not below 7 %); the
    hold at 8 s is PX4's COM_FAIL_ACT_T delay, the return at 13 s the reaction, 5 s after the trigger."""
    judge = FailsafeJudge("battery low", [], 0.07)
    battery_flight(judge, resting, [(1.0, FlightMode.AUTO_MISSION), (8.0, FlightMode.AUTO_LOITER),
                                    (13.0, FlightMode.AUTO_RTL)], land_at=30.0)
    expected = FailsafeExpected(after="battery low", action="rtl", within_s=6, landed_within_m_of_home=2)
    verdict = judge.failsafe_verdict(expected, Moment(0, 40.0))
    assert judge.trigger is not None and judge.trigger.mission_t == pytest.approx(8.0)
    assert verdict.met, verdict.line()
    assert verdict.found == ("battery low at mission time 8.00 s (sent 6 %), AUTO.RTL 5.00 s later (AUTO.LOITER "
                             "0.00 s after it), landed 1.00 m from home at mission time 30.00 s")
    assert verdict.decided_mission_t == pytest.approx(30.0)


def test_the_wrong_action_fails_saying_what_the_board_did_instead(resting):
    judge = FailsafeJudge("battery low", [], 0.07)
    battery_flight(judge, resting, [(1.0, FlightMode.AUTO_MISSION), (9.0, FlightMode.AUTO_LAND)], land_at=20.0)
    verdict = judge.failsafe_verdict(FailsafeExpected(after="battery low", action="rtl", within_s=6),
                                     Moment(0, 40.0))
    assert not verdict.met
    assert "AUTO.LAND 1.00 s later instead of AUTO.RTL" in verdict.line()


def test_a_board_that_does_nothing_meets_none_and_fails_an_action(resting):
    judge = FailsafeJudge("gps lost", [(5.0, math.inf)], 0.07)
    battery_flight(judge, resting, [(1.0, FlightMode.AUTO_MISSION)], land_at=100.0)
    end = Moment(0, 40.0)
    assert judge.failsafe_verdict(FailsafeExpected(after="gps lost", action="none", within_s=10), end).met
    verdict = judge.failsafe_verdict(FailsafeExpected(after="gps lost", action="land", within_s=10), end)
    assert not verdict.met and "the board flew no failsafe mode" in verdict.found
    assert judge.no_failsafe_verdict(end).met


def test_no_failsafe_fails_at_the_first_critical_heartbeat(resting):
    judge = FailsafeJudge(None, [], 0.07)
    battery_flight(judge, resting, [(1.0, FlightMode.AUTO_MISSION), (12.0, FlightMode.AUTO_RTL)], land_at=100.0)
    verdict = judge.no_failsafe_verdict(Moment(0, 40.0))
    assert not verdict.met and verdict.decided_mission_t == pytest.approx(12.0)
    assert verdict.found == "in a failsafe action (MAV_STATE_CRITICAL, AUTO.RTL) from mission time 12.00 s"


def test_a_trigger_that_never_came_says_so(resting):
    judge = FailsafeJudge("battery low", [], 0.07)
    battery_flight(judge, resting, [(1.0, FlightMode.AUTO_MISSION)], land_at=100.0, seconds=5.0)
    verdict = judge.failsafe_verdict(FailsafeExpected(after="battery low", action="rtl", within_s=6),
                                     Moment(0, 40.0))
    assert not verdict.met
    assert verdict.found == "the battery never went below BAT_CRIT_THR 0.07 (the lowest sent 10 %)"
