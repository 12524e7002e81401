"""The bench pilot without a board: fed what a board would report, step by step, it asks what PX4's offboard
interface needs in PX4's order, runs the mission clock on the bench's integer steps, and ends a flight that goes
wrong. Its decisions are checked against hand-made facts, not against a flight."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from pymavlink.dialects.v20.common import MAV_RESULT_ACCEPTED, MAV_RESULT_TEMPORARILY_REJECTED

from firmware_interface.board_report import BoardInfo, BoardReport
from firmware_interface.board_requests import ARM, OFFBOARD, ParamSet
from hil.exit_codes import EXIT_BOARD, EXIT_EXPECT_FAILED
from hil.loop.pilot import PilotView, RunAborted
from hil.pilots.bench import ARM_RETRY_S, DISARMED_IN_FLIGHT_S, SETPOINTS_BEFORE_OFFBOARD_S, BenchPilot
from hil.scenario.loader import load_scenario
from hil.scenario.mission import MissionPlan
from plant_fmu import Plant

DT_US = 4000
ROOT = Path(__file__).resolve().parent.parent


class FakeLocal:
    """LOCAL_POSITION_NED as a board reports it: its own origin, 1 m north and 2 m east of the truth's."""

    x, y, z = 1.0, 2.0, 0.0


@pytest.fixture
def on_ground():
    plant = Plant({})
    yield plant.state()
    plant.close()


def pilot_and_view(on_ground, params: dict[str, float] | None = None) -> tuple[BenchPilot, PilotView, list[str]]:
    scenario = load_scenario(ROOT / "scenarios" / "hover.yaml")
    events: list[str] = []
    view = PilotView(BoardReport(), "pty", events.append, params or {}, truth=on_ground, outputs_armed=False)
    return BenchPilot(MissionPlan.build(scenario), scenario.end, DT_US), view, events


def step(pilot: BenchPilot, view: PilotView, k: int):
    view.now_s = k * DT_US / 1e6
    return pilot.decide(view)


def test_nothing_is_asked_before_the_boards_heartbeat_and_arming_is_asked_each_second_after(on_ground):
    pilot, view, _ = pilot_and_view(on_ground)
    quiet = [step(pilot, view, k) for k in range(10)]
    assert all(d.asks == () and d.phase == "preflight" and d.reference is None and not d.flying for d in quiet)
    view.board.info = BoardInfo(1, 1, 12, 2, True, False)
    asks = [(k, step(pilot, view, k).asks) for k in range(10, 10 + round(2.5 * 1e6 / DT_US))]
    arm_steps = [k for k, a in asks if a == (ARM,)]
    assert arm_steps[0] == 10 and np.allclose(np.diff(arm_steps) * DT_US / 1e6, ARM_RETRY_S)


def test_owed_parameters_are_set_and_read_back_before_arming(on_ground):
    pilot, view, events = pilot_and_view(on_ground, {"EKF2_GPS_DELAY": 120.0})
    view.board.info = BoardInfo(1, 1, 12, 2, True, False)
    assert step(pilot, view, 0).asks == (ParamSet("EKF2_GPS_DELAY", 120.0),)
    view.board.params["EKF2_GPS_DELAY"] = 120.0  # PARAM_VALUE came back
    arm_asked = next(k for k in range(1, 1000) if step(pilot, view, k).asks == (ARM,))
    assert arm_asked * DT_US / 1e6 == pytest.approx(ARM_RETRY_S)  # one retry period after the PARAM_SET
    assert events == ["board parameters set: EKF2_GPS_DELAY = 120"]


def test_armed_then_offboard_then_the_mission_clock_runs_on_the_benchs_steps(on_ground):
    pilot, view, events = pilot_and_view(on_ground)
    view.board.info = BoardInfo(1, 1, 12, 2, True, False)
    view.board.latest["LOCAL_POSITION_NED"] = FakeLocal()
    step(pilot, view, 0)
    view.board.acks[ARM.command] = MAV_RESULT_ACCEPTED
    armed = step(pilot, view, 1)
    assert armed.phase == "offboard" and armed.reference is not None
    assert armed.board_offset_ned == pytest.approx(np.array([1.0, 2.0, 0.0]) - on_ground.pos_ned)
    first_offboard = next(k for k in range(2, 200) if step(pilot, view, k).asks == (OFFBOARD,))
    streamed_s = (first_offboard - 1) * DT_US / 1e6  # setpoints stream before offboard is asked
    assert SETPOINTS_BEFORE_OFFBOARD_S <= streamed_s <= SETPOINTS_BEFORE_OFFBOARD_S + DT_US / 1e6
    view.board.acks[OFFBOARD.command] = MAV_RESULT_ACCEPTED
    view.outputs_armed = True
    clocks = [step(pilot, view, first_offboard + 1 + k) for k in range(5)]
    assert [d.phase for d in clocks] == ["takeoff"] * 5 and all(d.flying for d in clocks)
    takeoff_s = pilot.plan.takeoff_s
    assert [d.mission_t for d in clocks] == [(-round(takeoff_s * 1e6) + k * DT_US) / 1e6 for k in range(5)]
    assert events[-1] == f"phase offboard -> takeoff at {(first_offboard + 1) * DT_US / 1e6:.3f} s"


def test_offboard_refused_for_five_seconds_is_a_board_failure_with_its_reason(on_ground):
    pilot, view, _ = pilot_and_view(on_ground)
    view.board.info = BoardInfo(1, 1, 12, 2, True, False)
    view.board.acks[ARM.command] = MAV_RESULT_ACCEPTED
    view.board.acks[OFFBOARD.command] = MAV_RESULT_TEMPORARILY_REJECTED
    view.board.status_texts.append((4, "Offboard denied: no setpoints"))
    with pytest.raises(RunAborted) as caught:
        for k in range(round(6.0 * 1e6 / DT_US)):
            step(pilot, view, k)
    assert caught.value.exit_code == EXIT_BOARD
    assert caught.value.reason == f"offboard mode refused (MAV_RESULT {MAV_RESULT_TEMPORARILY_REJECTED}): " \
                                  "Offboard denied: no setpoints"


def test_a_board_whose_outputs_say_disarmed_in_flight_ends_the_flight(on_ground):
    pilot, view, _ = pilot_and_view(on_ground)
    view.board.info = BoardInfo(1, 1, 12, 2, True, False)
    view.board.acks[ARM.command] = view.board.acks[OFFBOARD.command] = MAV_RESULT_ACCEPTED
    step(pilot, view, 0)  # armed: offboard
    step(pilot, view, 1)  # offboard accepted: take-off
    assert pilot.phase == "takeoff"
    view.outputs_armed = False  # a failsafe disarmed it
    steps = math.floor(DISARMED_IN_FLIGHT_S * 1e6 / DT_US) + 2
    with pytest.raises(RunAborted) as caught:
        for k in range(2, 2 + steps + 1):
            step(pilot, view, k)
    assert caught.value.exit_code == EXIT_EXPECT_FAILED and "disarmed in flight at 0.008 s" in caught.value.reason
