"""The parts of a mission flight without a board: the QGroundControl plan read into items, the planned legs and the
distance from them (hand-derived), what counts as an item reached when PX4 reports what it reports, the upload
with the mission protocol (MAVLink messages packed and decoded by pymavlink, as the board's would be), and the
mission and external pilots fed, step by step, what a board would report."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from pymavlink.dialects.v20 import common

from firmware_interface.board import BENCH_COMPONENT_ID
from firmware_interface.board_report import BoardInfo, BoardReport
from firmware_interface.board_requests import ARM, ParamSet, ProtocolMessage
from firmware_interface.geodesy import LocalFrame
from firmware_interface.hil_codec import SensorReadings
from firmware_interface.link import Message
from firmware_interface.px4_modes import PX4_AUTO_SUB_MODE_MISSION, PX4_MAIN_MODE_AUTO, custom_mode
from hil.boards.gcs_relay import default_endpoints
from hil.boards.registry import board_target
from hil.exit_codes import EXIT_BOARD, EXIT_EXPECT_FAILED
from hil.judge.behaviour import BehaviourJudge
from hil.judge.mission_progress import MissionProgress
from hil.judge.planned_path import Leg, PlannedPath
from hil.loop.frame import StepFrame
from hil.loop.pilot import PilotView, RunAborted
from hil.pilots.external import ExternalPilot
from hil.pilots.mission import MissionPilot
from hil.pilots.mission_upload import SILENCE_LIMIT_S, MissionUpload
from hil.scenario.environment import EnvironmentSample
from hil.scenario.loader import load_scenario
from hil.scenario.mission_items import PlanItem, read_plan_file, validate_items
from hil.scenario.schema import Bounds
from plant_fmu import Plant

ROOT = Path(__file__).resolve().parent.parent
DT_US = 4000
HOME = LocalFrame(47.397742, 8.545594, 488.0)
PX4 = common.MAVLink(None, srcSystem=1, srcComponent=1)
AUTO_MISSION = custom_mode(PX4_MAIN_MODE_AUTO, PX4_AUTO_SUB_MODE_MISSION)


def from_board(message: common.MAVLink_message) -> Message:
    """`message` as the bench receives it from PX4: packed to bytes and decoded."""
    return common.MAVLink(None).decode(bytearray(message.pack(PX4)))


def patrol_items() -> list[PlanItem]:
    return validate_items(read_plan_file(ROOT / "scenarios" / "patrol_mission.plan"), "patrol_mission.plan")


# --- the plan and its legs -----------------------------------------------------------------------
def test_the_patrol_plan_is_read_as_qgroundcontrol_wrote_it():
    items = patrol_items()
    assert [i.command for i in items] == [22, 178, 16, 16, 16, 20]
    assert items[0].params[3] is None and items[1].params[1] == 3.0  # yaw left to PX4; 3 m/s
    assert load_scenario(ROOT / "scenarios" / "patrol_mission.yaml").pilot.items == items


def test_the_patrol_legs_lie_5_m_beside_the_span_12_m_up():
    """The span runs from (0, 0) to (28.3, 28.3) m, north-east, 40 m long; 5 m to its north-west side is
    (+5/sqrt(2), -5/sqrt(2)) m north and east of each tower."""
    path = PlannedPath(patrol_items(), HOME)
    side = 5 / math.sqrt(2)
    assert path.points[2] == pytest.approx([side, -side, -12.0], abs=0.01)
    assert path.points[3] == pytest.approx([28.3 + side, 28.3 - side, -12.0], abs=0.01)
    assert path.leg_to(0) is None and path.leg_to(1) is None and path.leg_to(5) is None
    assert path.leg_to(2).start_ned == pytest.approx([0, 0, -12.0], abs=0.01)  # from the take-off point
    assert path.legs[3].length_m == pytest.approx(40.0, abs=0.05)


@pytest.mark.parametrize(("point", "cross", "along"), [((10, 3, -10), 3.0, 0.5), ((25, -4, -10), 4.0, 1.25),
                                                       ((10, 0, -13), 3.0, 0.5), ((-2, 0, -10), 0.0, -0.1)])
def test_cross_track_is_from_the_legs_line_and_along_track_a_fraction_of_it(point, cross, along):
    leg = Leg(np.array([0.0, 0.0, -10.0]), np.array([20.0, 0.0, -10.0]))
    assert leg.cross_and_along(np.array(point, dtype=float)) == pytest.approx((cross, along))


# --- what counts as reached --------------------------------------------------------------------
def test_px4s_reports_of_the_patrol_complete_it():
    """What PX4 v1.15.4 sent during the patrol (its tlog): no report for the take-off item or the final RTL item."""
    progress: MissionProgress[float] = MissionProgress(patrol_items())
    for t, (kind, value) in enumerate([("current", 0), ("reached", 1), ("current", 2), ("reached", 2),
                                       ("current", 3), ("reached", 3), ("current", 4), ("reached", 4),
                                       ("mode", "AUTO.RTL"), ("current", 5)]):
        {"current": progress.current_item, "reached": progress.item_reached, "mode": progress.mode}[kind](value, t)
    assert progress.complete and progress.reached == {1: 1, 0: 2, 2: 3, 3: 5, 4: 7, 5: 8}


def test_an_item_jumped_over_or_a_current_item_that_goes_back_is_not_a_completed_mission():
    jumped: MissionProgress[int] = MissionProgress(patrol_items())
    for seq in (0, 1, 2, 4):
        jumped.current_item(seq, seq)
    jumped.mode("AUTO.RTL", 9)
    assert not jumped.complete and jumped.missing() == [3, 4, 5]
    back: MissionProgress[int] = MissionProgress(patrol_items())
    for t, seq in enumerate((0, 2, 3, 2, 3, 4, 5)):
        back.current_item(seq, t)
    assert back.went_back and not back.complete


# --- the upload -----------------------------------------------------------------------------------
def requested(seq: int, component: int = BENCH_COMPONENT_ID, legacy: bool = False) -> Message:
    kind = common.MAVLink_mission_request_message if legacy else common.MAVLink_mission_request_int_message
    return from_board(kind(1, component, seq, common.MAV_MISSION_TYPE_MISSION))


def test_the_upload_answers_each_request_with_its_item_and_ends_on_the_boards_ack():
    items = patrol_items()
    upload = MissionUpload(items)
    (count,) = upload.step(0.0, [])
    assert count == ProtocolMessage("MISSION_COUNT", (("count", 6), ("mission_type", 0)))
    assert upload.step(0.5, []) == []  # nothing more until asked, or a second later
    first = dict(upload.step(0.6, [requested(0, legacy=True)])[0].fields)  # PX4 asks MISSION_REQUEST first
    assert (first["seq"], first["command"], first["frame"], first["current"]) == (0, 22, 3, 1)
    assert (first["x"], first["y"], first["z"]) == (473977420, 85455940, 12.0) and math.isnan(first["param4"])
    assert upload.step(0.7, [requested(1, component=190)]) == []  # another station's upload on the same link
    speed = dict(upload.step(0.8, [requested(1)])[0].fields)
    assert (speed["command"], speed["param2"], speed["x"], speed["y"]) == (178, 3.0, 0, 0)
    accepted = from_board(common.MAVLink_mission_ack_message(1, BENCH_COMPONENT_ID, common.MAV_MISSION_ACCEPTED, 0))
    upload.step(0.9, [accepted])
    assert upload.accepted and upload.failure is None


def test_an_upload_refused_or_never_answered_fails_with_why():
    refused = MissionUpload(patrol_items())
    refused.step(0.0, [from_board(common.MAVLink_mission_ack_message(1, BENCH_COMPONENT_ID,
                                                                     common.MAV_MISSION_NO_SPACE, 0))])
    assert refused.failure == "the board refused the mission: MAV_MISSION_NO_SPACE"
    silent = MissionUpload(patrol_items())
    counts = sum(len(silent.step(k * 0.1, [])) for k in range(int(SILENCE_LIMIT_S * 10) + 2))
    assert counts == SILENCE_LIMIT_S + 1 and "no item was requested" in (silent.failure or "")


# --- the mission pilot ----------------------------------------------------------------------------
@pytest.fixture
def on_ground():
    plant = Plant({})
    yield plant.state()
    plant.close()


def view_of(on_ground, owed: dict[str, float] | None = None) -> tuple[PilotView, list[str]]:
    events: list[str] = []
    return PilotView(BoardReport(), "udp", events.append, owed or {}, truth=on_ground), events


def at(view: PilotView, k: int, messages: list[Message] | None = None) -> PilotView:
    view.now_s, view.messages = k * DT_US / 1e6, messages or []
    return view


def test_the_mission_pilot_uploads_arms_starts_and_then_only_watches(on_ground):
    pilot = MissionPilot(patrol_items(), 120.0, DT_US)
    view, events = view_of(on_ground, {"EKF2_GPS_DELAY": 110.0})
    assert pilot.decide(at(view, 0)).asks == ()  # no heartbeat yet
    view.board.info = BoardInfo(1, 1, 12, 2, False, False)
    assert pilot.decide(at(view, 1)).asks == (ParamSet("EKF2_GPS_DELAY", 110.0),)
    view.board.params["EKF2_GPS_DELAY"] = 110.0
    pilot.decide(at(view, 2))
    assert pilot.decide(at(view, 3)).asks[0].type == "MISSION_COUNT"
    for seq in range(6):
        pilot.decide(at(view, 4 + seq, [requested(seq)]))
    pilot.decide(at(view, 10, [from_board(common.MAVLink_mission_ack_message(1, BENCH_COMPONENT_ID, 0, 0))]))
    assert pilot.decide(at(view, 11)).asks == (ARM,)
    view.board.acks[ARM.command] = 0
    pilot.decide(at(view, 12))
    start = pilot.decide(at(view, 13))
    assert start.asks[0].command == common.MAV_CMD_MISSION_START and start.asks[0].params == (0.0, 5.0)
    view.board.acks[common.MAV_CMD_MISSION_START] = 0
    view.board.armed, view.outputs_armed, view.board.custom_mode = True, True, AUTO_MISSION
    view.truth = dataclasses.replace(on_ground, pos_ned=np.array([0.0, 0.0, -1.0]), on_ground=False)
    flying = [pilot.decide(at(view, k)) for k in range(14, 30)]
    assert all(d.asks == () and d.reference is None for d in flying)  # it only watches
    assert flying[-1].phase == "mission" and flying[-1].flying and flying[-1].mission_t > 0
    assert "board mode AUTO.MISSION at 0.056 s" in events


def test_a_mission_not_finished_within_duration_s_of_take_off_fails(on_ground):
    pilot = MissionPilot(patrol_items(), 1.0, DT_US)
    view, _ = view_of(on_ground)
    pilot.phase = pilot.phase.__class__.STARTING
    view.board.info = BoardInfo(1, 1, 12, 2, False, True)
    view.board.armed = view.outputs_armed = True
    view.truth = dataclasses.replace(on_ground, pos_ned=np.array([0.0, 0.0, -3.0]), on_ground=False)
    with pytest.raises(RunAborted) as aborted:
        for k in range(400):
            pilot.decide(at(view, k))
    assert aborted.value.exit_code == EXIT_EXPECT_FAILED and "within duration_s = 1 s" in aborted.value.reason


def test_a_refused_mission_upload_is_a_board_failure(on_ground):
    pilot = MissionPilot(patrol_items(), 120.0, DT_US)
    view, _ = view_of(on_ground)
    view.board.info = BoardInfo(1, 1, 12, 2, False, False)
    pilot.decide(at(view, 0))
    with pytest.raises(RunAborted) as aborted:
        pilot.decide(at(view, 1, [from_board(common.MAVLink_mission_ack_message(
            1, BENCH_COMPONENT_ID, common.MAV_MISSION_UNSUPPORTED_FRAME, 0))]))
    assert aborted.value.exit_code == EXIT_BOARD and "MAV_MISSION_UNSUPPORTED_FRAME" in aborted.value.reason


# --- the external pilot ---------------------------------------------------------------------------
def test_the_external_pilot_asks_nothing_but_the_owed_parameters_and_ends_landed_and_disarmed(on_ground):
    pilot = ExternalPilot("landed", 600.0, DT_US)
    view, events = view_of(on_ground, {"EKF2_GPS_DELAY": 110.0})
    view.board.info = BoardInfo(1, 1, 12, 2, False, False)
    assert pilot.decide(at(view, 0)).asks == (ParamSet("EKF2_GPS_DELAY", 110.0),)
    view.board.params["EKF2_GPS_DELAY"] = 110.0
    decisions = [pilot.decide(at(view, k)) for k in range(1, 100)]
    view.board.armed, view.outputs_armed = True, True
    view.truth = dataclasses.replace(on_ground, pos_ned=np.array([0.0, 0.0, -2.0]), on_ground=False)
    decisions += [pilot.decide(at(view, k)) for k in range(100, 200)]
    assert all(d.asks == () and d.reference is None for d in decisions)
    assert decisions[-1].phase == "mission" and decisions[-1].mission_t == pytest.approx(99 * DT_US / 1e6)
    view.truth, view.outputs_armed, view.board.armed = on_ground, False, False
    view.board.latest["EXTENDED_SYS_STATE"] = from_board(common.MAVLink_extended_sys_state_message(
        0, common.MAV_LANDED_STATE_ON_GROUND))
    ending = [pilot.decide(at(view, 200))]
    while ending[-1] is not None:
        ending.append(pilot.decide(at(view, 200 + len(ending))))
    assert ending[0].phase == "grounded" and len(ending) == 1 + 1e6 / DT_US  # GROUNDED_S on, then done
    assert "the board is ready for its pilot: the bench commands nothing from here on" in events


def test_the_external_pilot_ends_at_duration_s_on_the_benchs_clock(on_ground):
    pilot = ExternalPilot("duration", 0.1, DT_US)
    view, events = view_of(on_ground)
    view.board.info = BoardInfo(1, 1, 12, 2, False, False)
    decisions = [pilot.decide(at(view, k)) for k in range(30)]
    assert decisions.index(None) == 25 and events[-1] == "duration_s = 0.1 s reached: the run ends"


# --- the behaviour judge --------------------------------------------------------------------------
def frame(on_ground, t_s: float, pos_ned: tuple[float, float, float], armed: bool,
          board: list[tuple[str, dict]] | None = None) -> StepFrame:
    """One step as the loop hands it on: the true state at `pos_ned`, on the mission clock from t = 0."""
    zero = np.zeros(3)
    truth = dataclasses.replace(on_ground, pos_ned=np.array(pos_ned), on_ground=pos_ned[2] >= 0)
    return StepFrame(round(t_s * 1e6) + 5_000_000, t_s, "mission", truth, None, SensorReadings(round(t_s * 1e6)),
                     None, (0.0,) * 4, armed, EnvironmentSample(zero, zero, zero, 0.0, (1.0,) * 4),
                     board=board or [])


def test_the_judge_decides_each_bound_at_the_step_that_breaks_it_and_a_met_one_at_its_moment(on_ground):
    """A square's first leg flown 4 m off its line from t = 3 s, 14 m up at t = 4 s, then home; judged against
    bounds of 3 m from the legs and 12 m of height, and asked for the modes it went through."""
    items = [PlanItem(command=16, params=(0, 0, 0, None, *HOME.to_geodetic(n, e, 0.0)[:2], 10.0))
             for n, e in ((0.0, 0.0), (20.0, 0.0))]
    bounds = Bounds(max_cross_track_m=3.0, max_altitude_m=12.0, home_within_m=1.0, disarmed_by_s=10.0,
                    modes_seen=["AUTO.MISSION", "AUTO.RTL"], mission_completed=True)
    judge = BehaviourJudge(PlannedPath(items, HOME), bounds, MissionProgress(items))
    beat = ("HEARTBEAT", {"armed": True, "custom_mode": AUTO_MISSION, "system_status": 4})
    judge.on_step(frame(on_ground, 0.0, (0.0, 0.0, -10.0), True, [beat, ("MISSION_CURRENT", {"seq": 0,
                                                                                           "total": 2})]))
    judge.on_step(frame(on_ground, 1.0, (5.0, 1.0, -10.0), True, [("MISSION_CURRENT", {"seq": 1, "total": 2})]))
    judge.on_step(frame(on_ground, 3.0, (10.0, 4.0, -10.0), True))  # 4 m off the leg: over 3 m here
    judge.on_step(frame(on_ground, 4.0, (15.0, 0.0, -14.0), True))  # 14 m up: over 12 m here
    judge.on_step(frame(on_ground, 6.0, (20.0, 0.0, -10.0), True, [("MISSION_ITEM_REACHED", {"seq": 1})]))
    judge.on_step(frame(on_ground, 8.0, (0.3, 0.4, 0.0), False))  # down 0.5 m from home, disarmed
    verdicts = {v.expectation: v for v in judge.verdicts(bounds)}
    assert not verdicts["max_cross_track_m"].met and verdicts["max_cross_track_m"].decided_mission_t == 3.0
    assert "max 4.00 m" in verdicts["max_cross_track_m"].found
    assert not verdicts["max_altitude_m"].met and verdicts["max_altitude_m"].decided_mission_t == 4.0
    assert verdicts["home_within_m"].met and verdicts["home_within_m"].decided_mission_t == 8.0
    assert verdicts["home_within_m"].found == "came to rest 0.50 m from home"
    assert verdicts["disarmed_by_s"].met and verdicts["disarmed_by_s"].decided_mission_t == 8.0
    assert not verdicts["modes_seen"].met and "never AUTO.RTL" in verdicts["modes_seen"].found
    # item 0 left for item 1 at t = 1 (MISSION_CURRENT), item 1 reported at t = 6
    assert verdicts["mission_completed"].met and verdicts["mission_completed"].decided_mission_t == 6.0


# --- where the relay sends by default -------------------------------------------------------------
@pytest.mark.parametrize(("spec", "pilot", "endpoints"), [
    ("emulator", "bench", ["udpout:127.0.0.1:14550"]),
    ("emulator", "external", ["udpout:127.0.0.1:14550", "udpout:127.0.0.1:14540"]),
    ("port:/dev/ttyACM0", "mission", ["udpout:127.0.0.1:14550", "udpout:127.0.0.1:14540"]),
    ("port:tcpin:127.0.0.1:4560", "external", []),  # PX4 SITL serves 14550 and 14540 itself
])
def test_the_relay_serves_qgroundcontrol_and_mavsdk_where_px4_sitl_would(spec, pilot, endpoints):
    scenario = load_scenario(ROOT / "scenarios" / "hover.yaml")
    assert default_endpoints(board_target(spec).policy(scenario).default_gcs, pilot == "bench") == endpoints
