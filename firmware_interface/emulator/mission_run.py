"""AUTO.MISSION: the stored mission flown item by item, as PX4 v1.15.4's Mission / MissionBlock fly it for a
multicopter (navigator/mission.cpp, mission_base.cpp, mission_block.cpp).

- At the start, when the first position item is higher than the vehicle by more than NAV_MC_ALT_RAD, a climb
  straight up to its altitude comes first ("Climb to … meters above home"; a take-off when on the ground).
- WAYPOINT, LOITER_TIME, TAKEOFF: a move to the item; reached when within its acceptance radius (WAYPOINT's
  param2, else NAV_ACC_RAD) horizontally and NAV_MC_ALT_RAD vertically, then held for param1 seconds; then
  MISSION_ITEM_REACHED and the next item, whose move starts from the reference where it is (no stop).
- LAND: a move to the item at the current altitude, then PX4's land descent; reached once landed.
- DO_CHANGE_SPEED: the cruise speed (param2 > 0, else back to MPC_XY_CRUISE) for the legs that follow; reached at once.
- RETURN_TO_LAUNCH: AUTO.RTL (PX4 issues the command; no MISSION_ITEM_REACHED for it, as in PX4 v1.15).
- After the last item: "Mission finished, loitering" and AUTO.LOITER (or "Mission finished, landed").
"""

from __future__ import annotations

import math

import numpy as np
from pymavlink.dialects.v20.common import (
    MAV_CMD_DO_CHANGE_SPEED,
    MAV_CMD_NAV_LAND,
    MAV_CMD_NAV_RETURN_TO_LAUNCH,
    MAV_CMD_NAV_TAKEOFF,
    MAV_SEVERITY_INFO,
)

from firmware_interface.emulator.control import VehicleState
from firmware_interface.emulator.mission_items import MissionItem
from firmware_interface.emulator.mission_protocol import MissionServer
from firmware_interface.emulator.navigator import Navigator, last_at_rest, state_setpoint
from firmware_interface.emulator.trajectory import Move
from firmware_interface.px4_modes import FlightMode

MIN_LEG_FOR_HEADING_M = 1.0  # a leg shorter than this keeps the heading it has


class MissionRun:
    def __init__(self, navigator: Navigator, missions: MissionServer, state: VehicleState, t_us: int) -> None:
        self.navigator, self.missions = navigator, missions
        navigator.task = self  # before the first item: it may hand over to AUTO.RTL at once
        if missions.finished:
            missions.finished, missions.current_seq = False, 0
        self.seq = missions.current_seq
        self.target = np.zeros(3)  # the current item's position, local NED
        self.move: Move | None = None
        self.phase = "climb"  # climb, item, approach (LAND), landing
        self.reached_since_us: int | None = None
        self.taking_off = not navigator.vehicle.airborne
        if navigator.last is None or not navigator.vehicle.airborne:
            navigator.last = state_setpoint(state)
        self._begin(state, t_us, first=True)

    # --- starting an item ------------------------------------------------------------------------------
    def _begin(self, state: VehicleState, t_us: int, first: bool = False) -> None:
        """Act on the items from `seq` until one needs flying to (or the mission ends)."""
        items = self.missions.items
        while self.seq < len(items) and not items[self.seq].has_position:
            if not self._action(items[self.seq]):
                return
            self.missions.reached(self.seq)
            self.seq += 1
        if self.seq >= len(items):
            self._finish()
            return
        self.missions.advance(self.seq)
        item = items[self.seq]
        previous = None if first or self.phase != "item" else self.target  # the item just flown: the leg starts there
        self.target = target = self._target(item)
        self.reached_since_us = None
        last = self.navigator.last
        assert last is not None
        if first and float(target[2]) < float(state.pos_ned[2]) - self.navigator.params["NAV_MC_ALT_RAD"]:
            self._climb(t_us, target)
        elif item.command == MAV_CMD_NAV_LAND:
            self.phase = "approach"
            self.move = self.navigator.move_to(np.array((target[0], target[1], last.pos_ned[2])), t_us, item.yaw_rad)
        else:
            self.phase = "item"
            self.move = self.navigator.move_to(target, t_us, self._heading(item, target), previous)

    def _climb(self, t_us: int, target: np.ndarray) -> None:
        navigator = self.navigator
        home = navigator.vehicle.home_ned()
        above_home = float((home[2] if home is not None else 0.0) - target[2])
        navigator.vehicle.status(MAV_SEVERITY_INFO, f"Climb to {above_home:.1f} meters above home")
        self.phase = "climb"
        start = navigator.last
        assert start is not None
        climb = np.array((start.pos_ned[0], start.pos_ned[1], target[2]))
        self.move = Move(start, t_us, climb, None, navigator.climb_limits() if self.taking_off else navigator.limits())
        navigator.reference = self.move

    def _action(self, item: MissionItem) -> bool:
        """An item without a position; False when it ends the mission mode (RTL)."""
        if item.command == MAV_CMD_DO_CHANGE_SPEED:
            speed = item.params[1]
            self.navigator.cruise_speed = speed if math.isfinite(speed) and speed > 0 else None
            return True
        if item.command == MAV_CMD_NAV_RETURN_TO_LAUNCH:
            self.missions.advance(self.seq)
            self.navigator.vehicle.request_mode(FlightMode.AUTO_RTL)
        return False

    # --- at the navigator's rate -----------------------------------------------------------------------
    def tick(self, state: VehicleState, t_us: int) -> None:
        if self.seq >= len(self.missions.items) or self.phase == "landing":
            return
        item, target = self.missions.items[self.seq], self.target
        if self.phase == "climb":
            if self.navigator.altitude_reached(state, float(target[2])):
                self.taking_off = False
                self.phase = "item"
                self.move = self.navigator.move_to(target, t_us, self._heading(item, target))
        elif self.phase == "approach":
            if self.move is not None and self.move.finished(t_us) and self._within_xy(state, target, item):
                self.phase = "landing"
                self.navigator.descend_from(last_at_rest(self.navigator))
        elif self._item_reached(state, target, item, t_us):
            self.missions.reached(self.seq)
            self.seq += 1
            self._begin(state, t_us)

    def landed(self) -> None:
        """The land detector fired during a LAND item: the item and the mission are done."""
        if self.phase == "landing":
            self.missions.reached(self.seq)
            self.seq += 1
            self._finish(landed=True)

    def _item_reached(self, state: VehicleState, target: np.ndarray, item: MissionItem, t_us: int) -> bool:
        if self.reached_since_us is None:
            close = self._within_xy(state, target, item) and abs(float(state.pos_ned[2] - target[2])) <= \
                self.navigator.params["NAV_MC_ALT_RAD"]
            if not close:
                return False
            self.reached_since_us = t_us
        return (t_us - self.reached_since_us) * 1e-6 >= item.hold_s

    def _within_xy(self, state: VehicleState, target: np.ndarray, item: MissionItem) -> bool:
        radius = item.acceptance_radius_m or self.navigator.params["NAV_ACC_RAD"]
        return math.hypot(float(state.pos_ned[0] - target[0]), float(state.pos_ned[1] - target[1])) <= radius

    def _finish(self, landed: bool = False) -> None:
        vehicle = self.navigator.vehicle
        self.navigator.task = None
        self.missions.finished = True
        if landed or not vehicle.airborne:
            vehicle.status(MAV_SEVERITY_INFO, "Mission finished, landed")
            return
        vehicle.status(MAV_SEVERITY_INFO, "Mission finished, loitering")
        vehicle.mode_completed(FlightMode.AUTO_MISSION)

    # --- geometry --------------------------------------------------------------------------------------------
    def _target(self, item: MissionItem) -> np.ndarray:
        """The item's position in the board's local NED frame (relative altitudes above home)."""
        vehicle = self.navigator.vehicle
        frame, home = vehicle.local_frame(), vehicle.home_ned()
        assert frame is not None
        home_amsl = frame.alt0_m - (float(home[2]) if home is not None else 0.0)
        altitude = item.altitude_m + (home_amsl if item.relative_alt else 0.0)
        if item.command == MAV_CMD_NAV_TAKEOFF and item.lat_deg == 0.0 and item.lon_deg == 0.0:
            last = self.navigator.last
            assert last is not None
            return np.array((last.pos_ned[0], last.pos_ned[1], frame.alt0_m - altitude))
        return np.array(frame.to_ned(item.lat_deg, item.lon_deg, altitude))

    def _heading(self, item: MissionItem, target: np.ndarray) -> float | None:
        """The item's yaw, else along the leg (PX4's MPC_YAW_MODE 0), else unchanged."""
        if item.yaw_rad is not None:
            return item.yaw_rad
        last = self.navigator.last
        assert last is not None
        north, east = float(target[0] - last.pos_ned[0]), float(target[1] - last.pos_ned[1])
        return math.atan2(east, north) if math.hypot(north, east) > MIN_LEG_FOR_HEADING_M else None

