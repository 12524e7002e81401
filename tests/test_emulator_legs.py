"""The emulator's legs from a moving reference (in process): a velocity or acceleration the reference carries into
a leg is taken off within the acceleration limits, so the reference stays by the leg's line however long the leg.

What these tests would have caught: each move was one quintic per axis from the whole moving reference to the
target over the leg's whole duration T, which carries a velocity v across the leg for T (0.1975·v·T off the line)
and an acceleration a for T² (0.0173·a·T²). On the shipped patrol the leg after the first corner began at 2.9 m/s
across it and 0.35 m/s² down: the reference left the leg by 4.8 m and sank 3.5 m, and SMARC tracked it there."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from pymavlink.dialects.v20 import common

from firmware_interface.emulator.control import Setpoint, VehicleState
from firmware_interface.emulator.mission_items import MissionItem, parse_item
from firmware_interface.emulator.mission_protocol import MissionServer
from firmware_interface.emulator.mission_run import MissionRun
from firmware_interface.emulator.navigator import NAVIGATOR_PERIOD_US, Navigator
from firmware_interface.emulator.px4_params import Px4Values
from firmware_interface.emulator.trajectory import Limits, Move
from firmware_interface.geodesy import LocalFrame
from firmware_interface.px4_modes import FlightMode
from hil.judge.planned_path import PlannedPath
from hil.pilots.mission_upload import item_message
from hil.scenario.loader import load_scenario

PATROL = Path(__file__).resolve().parent.parent / "scenarios" / "patrol_mission.yaml"
DT_US = 4000  # the bench's 250 Hz
# the patrol's: 3 m/s cruise (its DO_CHANGE_SPEED), PX4's MPC_ACC_HOR 3, MPC_ACC_UP_MAX 4, MPC_ACC_DOWN_MAX 3
LIMITS = Limits(speed_xy=3.0, speed_up=3.0, speed_down=1.5, accel_xy=3.0, accel_up=4.0, accel_down=3.0,
                yaw_rate=math.radians(45))


def distances_from_line(move: Move, origin: np.ndarray, end: np.ndarray) -> np.ndarray:
    """Distance (m) of the move's reference from the line origin → end at every 250 Hz step until it ends."""
    unit = (end - origin) / np.linalg.norm(end - origin)
    steps = (move.end_us - move.start_us) // DT_US + 2
    offsets = np.array([move.sample(move.start_us + k * DT_US, DT_US * 1e-6).pos_ned - origin for k in range(steps)])
    return np.linalg.norm(offsets - np.outer(offsets @ unit, unit), axis=1)


@pytest.mark.parametrize(("across", "accel", "brake_m"), [
    ((0.0, -2.0, 0.0), (0.0, 0.0, 0.0), 2.0**2 / LIMITS.accel_xy),  # 2 m/s across a northward leg
    ((0.0, 0.0, -0.7), (0.0, 0.0, 0.35), 0.7**2 / LIMITS.accel_down),  # still climbing, slowing, at a level leg
], ids=["across", "climbing"])
def test_what_a_leg_starts_with_across_it_costs_a_braking_distance_not_a_share_of_the_leg(across, accel, brake_m):
    """Stopping a velocity v at most at the acceleration limit a takes at least v²/2a; the reference may leave the
    line by up to v²/a (a smooth stop is longer than a bang-bang one), the same on a 40 m leg as on a 120 m one."""
    start = Setpoint(np.zeros(3), np.array(across), np.array(accel), 0.0)
    excursions = []
    for length in (40.0, 120.0):
        end = np.array((length, 0.0, 0.0))
        move = Move(start, 0, end, None, LIMITS)
        distance = distances_from_line(move, np.zeros(3), end)
        excursions.append(distance.max())
        assert distance.max() <= brake_m
        assert move.sample(move.end_us, 0.004).pos_ned == pytest.approx(end)
    assert excursions[0] == pytest.approx(excursions[1], abs=1e-6)


def test_a_leg_from_its_previous_waypoint_brings_a_reference_beside_it_onto_its_line():
    """The patrol's first corner as the emulator met it: the item reached 2 m short of it (NAV_ACC_RAD), the
    reference still at 2.9 m/s along the leg before; the next leg's line runs from the corner."""
    corner, target = np.array((3.5, -3.5, -12.0)), np.array((31.8, 24.7, -12.0))
    start = Setpoint(np.array((1.98, -2.25, -12.0)), np.array((2.01, -2.11, -0.05)), np.array((-0.58, 0.75, 0.35)),
                     -0.8)
    move = Move(start, 0, target, None, LIMITS, line_start=corner)
    distance = distances_from_line(move, corner, target)
    assert distance[0] == pytest.approx(1.96, abs=0.01)  # where the switch left it: 1.52·0.706 + 1.25·0.708
    assert distance.max() <= distance[0] + 1e-9  # from there only closer
    assert distance[round(move.blend_s * 1e6) // DT_US + 1:].max() < 1e-9  # on the line once the blend is over


class ExactVehicle:
    """The board around the navigator, reduced to what the navigator asks of it, on a vehicle that is wherever
    its reference is (what the navigator's reference does, without a controller's tracking error)."""

    def __init__(self, frame: LocalFrame) -> None:
        self.frame = frame
        self.airborne = False
        self.returning = False  # the mission handed over to AUTO.RTL

    def status(self, severity: int, text: str) -> None:
        pass

    def mode_completed(self, mode: FlightMode) -> None:
        pass

    def request_mode(self, mode: FlightMode) -> None:
        self.returning = mode is FlightMode.AUTO_RTL

    def descent_started(self) -> None:
        pass

    def local_frame(self) -> LocalFrame:
        return self.frame

    def home_ned(self) -> np.ndarray:
        return np.zeros(3)


def uploaded(items: list) -> list[MissionItem]:
    """The plan's items as the mission pilot sends them (MISSION_ITEM_INT) and the emulator stores them."""
    stored = []
    for seq, item in enumerate(items):
        fields = dict(item_message(seq, item).fields)
        message = common.MAVLink_mission_item_int_message(target_system=1, target_component=1, **fields)
        parsed = parse_item(message, int_encoded=True)
        assert isinstance(parsed, MissionItem)
        stored.append(parsed)
    return stored


def test_the_patrol_missions_reference_stays_within_the_acceptance_radius_of_its_legs():
    """The shipped patrol's plan through the emulator's navigator (PX4's defaults: NAV_ACC_RAD 2 m, NAV_MC_ALT_RAD
    0.8 m): while each leg is flown its reference is no farther from the leg's line than the item switch leaves it
    (within NAV_ACC_RAD of the waypoint just reached), and never off the patrol's 12 m by more than
    NAV_MC_ALT_RAD."""
    scenario = load_scenario(PATROL)
    frame, params = scenario.home.frame, Px4Values()
    path = PlannedPath(scenario.pilot.items, frame)
    missions = MissionServer(1, lambda name, fields: None, lambda severity, text: None, lambda: None)
    missions.items = uploaded(scenario.pilot.items)
    vehicle = ExactVehicle(frame)
    navigator = Navigator(params, vehicle)
    state = VehicleState(np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3))
    MissionRun(navigator, missions, state, 0)
    cross, heights, t_us = [], [], 0
    while not vehicle.returning:
        reference = navigator.setpoint(state, t_us, DT_US * 1e-6)
        state = VehicleState(reference.pos_ned, reference.vel_ned, np.array((0.0, 0.0, reference.yaw)), np.zeros(3))
        vehicle.airborne = vehicle.airborne or float(reference.pos_ned[2]) < -0.3
        leg = path.leg_to(missions.current_seq)
        if leg is not None:
            cross.append(leg.cross_and_along(reference.pos_ned)[0])
            heights.append(-float(reference.pos_ned[2]))
        if t_us % NAVIGATOR_PERIOD_US == 0:
            navigator.tick(state, t_us)
        t_us += DT_US
        assert t_us < 120_000_000, "the mission did not reach its RETURN_TO_LAUNCH"
    assert missions.reached_seq == 4  # the last waypoint, then the return
    assert max(cross) <= params["NAV_ACC_RAD"]
    assert max(abs(h - 12.0) for h in heights) <= params["NAV_MC_ALT_RAD"]
