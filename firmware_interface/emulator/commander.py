"""The emulator's commander: the flight mode, arming, and the commands a ground station sends, answered with
COMMAND_ACK as PX4 v1.15.4's Commander and navigator answer them (Commander.cpp handle_command,
UserModeIntention.cpp, ModeUtil/mode_requirements.cpp).

A mode change is always taken while disarmed; armed, only into a mode that can run now (position estimate;
a mission for AUTO.MISSION; home for AUTO.RTL; a fresh offboard setpoint for OFFBOARD), else
TEMPORARILY_REJECTED. Arming needs the estimator settled and a mode that can run and does not forbid arming
(AUTO.RTL, AUTO.LAND). Differences from PX4: POSCTL and MANUAL run without stick input (they hold position),
because the bench arms in POSCTL; the estimator check answers DENIED with its own text; after the land detector
fires and after a disarm the mode is POSCTL (PX4 keeps the mode until the disarm, then returns to the last
mode that allows arming).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from pymavlink.dialects.v20.common import (
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_CMD_DO_CHANGE_SPEED,
    MAV_CMD_DO_REPOSITION,
    MAV_CMD_DO_SET_MISSION_CURRENT,
    MAV_CMD_DO_SET_MODE,
    MAV_CMD_MISSION_START,
    MAV_CMD_NAV_LAND,
    MAV_CMD_NAV_RETURN_TO_LAUNCH,
    MAV_CMD_NAV_TAKEOFF,
    MAV_COMP_ID_MISSIONPLANNER,
    MAV_FRAME_GLOBAL,
    MAV_FRAME_GLOBAL_INT,
    MAV_FRAME_GLOBAL_RELATIVE_ALT,
    MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
    MAV_MODE_FLAG_AUTO_ENABLED,
    MAV_MODE_FLAG_GUIDED_ENABLED,
    MAV_MODE_FLAG_MANUAL_INPUT_ENABLED,
    MAV_MODE_FLAG_STABILIZE_ENABLED,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_DENIED,
    MAV_RESULT_TEMPORARILY_REJECTED,
    MAV_RESULT_UNSUPPORTED,
    MAV_SEVERITY_CRITICAL,
    MAV_SEVERITY_INFO,
    MAV_SEVERITY_WARNING,
)

from firmware_interface import hil_codec as codec
from firmware_interface.px4_modes import (
    FORCE_DISARM_MAGIC,
    PX4_AUTO_SUB_MODE_LAND,
    PX4_AUTO_SUB_MODE_LOITER,
    PX4_AUTO_SUB_MODE_MISSION,
    PX4_AUTO_SUB_MODE_RTL,
    PX4_AUTO_SUB_MODE_TAKEOFF,
    PX4_MAIN_MODE_AUTO,
    PX4_MAIN_MODE_MANUAL,
    PX4_MAIN_MODE_OFFBOARD,
    PX4_MAIN_MODE_POSCTL,
    FlightMode,
)

if TYPE_CHECKING:
    from firmware_interface.emulator.firmware import EmulatedBoard

PREVENTS_ARMING = (FlightMode.AUTO_RTL, FlightMode.AUTO_LAND)
THROTTLE_ABOVE_CENTER = 0.2  # Commander.cpp: manual_control_setpoint.throttle > 0.2
_GLOBAL_FRAMES = (MAV_FRAME_GLOBAL, MAV_FRAME_GLOBAL_INT, MAV_FRAME_GLOBAL_RELATIVE_ALT,
                  MAV_FRAME_GLOBAL_RELATIVE_ALT_INT)
_AUTO_SUB_MODES = {PX4_AUTO_SUB_MODE_TAKEOFF: FlightMode.AUTO_TAKEOFF, PX4_AUTO_SUB_MODE_LOITER: FlightMode.AUTO_LOITER,
                   PX4_AUTO_SUB_MODE_MISSION: FlightMode.AUTO_MISSION, PX4_AUTO_SUB_MODE_RTL: FlightMode.AUTO_RTL,
                   PX4_AUTO_SUB_MODE_LAND: FlightMode.AUTO_LAND}


@dataclass(frozen=True)
class Command:
    """A COMMAND_LONG or COMMAND_INT with its params as PX4's vehicle_command holds them (param5/6 in degrees
    for a COMMAND_INT in a global frame)."""

    command: int
    params: tuple[float, float, float, float, float, float, float]
    source: tuple[int, int]

    @classmethod
    def from_message(cls, msg: Any) -> Command:
        if msg.get_type() == "COMMAND_INT":
            scale = 1e-7 if msg.frame in _GLOBAL_FRAMES else 1.0
            params = (msg.param1, msg.param2, msg.param3, msg.param4, msg.x * scale, msg.y * scale, msg.z)
        else:
            params = (msg.param1, msg.param2, msg.param3, msg.param4, msg.param5, msg.param6, msg.param7)
        return cls(msg.command, tuple(float(p) for p in params), (msg.get_srcSystem(), msg.get_srcComponent()))  # type: ignore[arg-type]


def mode_from_set_mode(base_mode: int, main_mode: int, sub_mode: int) -> FlightMode | None:
    """DO_SET_MODE's params as PX4 reads them; None for a mode the emulator does not fly."""
    if base_mode & codec.MODE_FLAG_CUSTOM:
        if main_mode == PX4_MAIN_MODE_AUTO:
            return _AUTO_SUB_MODES.get(sub_mode) if sub_mode else FlightMode.AUTO_MISSION
        return {PX4_MAIN_MODE_MANUAL: FlightMode.MANUAL, PX4_MAIN_MODE_POSCTL: FlightMode.POSCTL,
                PX4_MAIN_MODE_OFFBOARD: FlightMode.OFFBOARD}.get(main_mode)
    if base_mode & MAV_MODE_FLAG_AUTO_ENABLED:
        return FlightMode.AUTO_MISSION
    if base_mode & MAV_MODE_FLAG_MANUAL_INPUT_ENABLED:
        if base_mode & MAV_MODE_FLAG_GUIDED_ENABLED:
            return FlightMode.POSCTL
        return None if base_mode & MAV_MODE_FLAG_STABILIZE_ENABLED else FlightMode.MANUAL
    return None


def base_mode_flags(mode: FlightMode) -> int:
    """HEARTBEAT.base_mode's control flags as PX4 derives them from its vehicle_control_mode."""
    if mode.is_auto:
        return MAV_MODE_FLAG_AUTO_ENABLED | MAV_MODE_FLAG_STABILIZE_ENABLED | MAV_MODE_FLAG_GUIDED_ENABLED
    if mode is FlightMode.OFFBOARD:
        return MAV_MODE_FLAG_STABILIZE_ENABLED
    return MAV_MODE_FLAG_MANUAL_INPUT_ENABLED | MAV_MODE_FLAG_STABILIZE_ENABLED


class Commander:
    def __init__(self, board: EmulatedBoard) -> None:
        self.board = board
        self.mode = FlightMode.POSCTL  # the mode flown (HEARTBEAT's)
        self.user_mode = FlightMode.POSCTL  # the mode the user chose (PX4's user intention): a failsafe overrides
        self.failsafe = False  # a failsafe chose the mode flown
        self._handlers: dict[int, Callable[[Command], int]] = {
            MAV_CMD_COMPONENT_ARM_DISARM: self._arm_disarm, MAV_CMD_NAV_TAKEOFF: self._takeoff,
            MAV_CMD_NAV_LAND: self._land, MAV_CMD_NAV_RETURN_TO_LAUNCH: self._return,
            MAV_CMD_DO_SET_MODE: self._set_mode, MAV_CMD_MISSION_START: self._mission_start,
            MAV_CMD_DO_SET_MISSION_CURRENT: self._set_mission_current, MAV_CMD_DO_CHANGE_SPEED: self._change_speed,
            MAV_CMD_DO_REPOSITION: self._reposition,
        }

    def handle(self, command: Command) -> int:
        """The MAV_RESULT for a command; UNSUPPORTED for one the commander does not handle."""
        handler = self._handlers.get(command.command)
        return handler(command) if handler is not None else MAV_RESULT_UNSUPPORTED

    # --- modes -------------------------------------------------------------------------------------------
    def can_run(self, mode: FlightMode) -> bool:
        board = self.board
        if mode is FlightMode.OFFBOARD:
            return board.offboard.fresh(board.now_us, board.params["COM_OF_LOSS_T"])
        if not board.position_ok():
            return False
        if mode is FlightMode.AUTO_MISSION:
            return bool(board.missions.items)
        if mode is FlightMode.AUTO_RTL:
            return board.home is not None
        return True

    def change_mode(self, mode: FlightMode, source_component: int = 0) -> int:
        """A mode change asked by a user (a command): taken, or TEMPORARILY_REJECTED when armed and it cannot run."""
        if self.board.armed and not self.can_run(mode):
            if source_component == MAV_COMP_ID_MISSIONPLANNER:
                self.board.status(MAV_SEVERITY_CRITICAL, f"Switching to {mode.ui_name} is currently not available")
            return MAV_RESULT_TEMPORARILY_REJECTED
        self.user_mode = mode
        self.board.failsafes.user_mode_changed()
        # the same mode again is no transition (a take-off command, though, sets a new altitude)
        if mode is not self.mode or self.failsafe or mode is FlightMode.AUTO_TAKEOFF:
            self.enter(mode)
        return MAV_RESULT_ACCEPTED

    def enter(self, mode: FlightMode, failsafe: bool = False, blind: bool = False) -> None:
        """Fly `mode` (armed, from now on); a failsafe's choice leaves the user's mode as it is."""
        self.mode, self.failsafe = mode, failsafe
        if not failsafe:
            self.user_mode = mode
        if self.board.armed:
            self.board.fly(mode, blind)

    def reset(self, mode: FlightMode = FlightMode.POSCTL) -> None:
        """The mode after a disarm or a landing (see the module's docstring)."""
        self.mode = self.user_mode = mode
        self.failsafe = False

    # --- arming ------------------------------------------------------------------------------------------
    def _arm_disarm(self, command: Command) -> int:
        action = round(command.params[0])
        if action not in (0, 1):
            self.board.status(MAV_SEVERITY_CRITICAL, f"Unsupported ARM_DISARM param: {command.params[0]:.3f}")
            return MAV_RESULT_UNSUPPORTED
        if action == 1:
            return self.arm()
        forced = round(command.params[1]) == FORCE_DISARM_MAGIC
        if self.board.airborne and not forced:
            self.board.status(MAV_SEVERITY_CRITICAL, "Disarming denied: not landed")
            return MAV_RESULT_TEMPORARILY_REJECTED
        self.board.disarm()
        return MAV_RESULT_ACCEPTED

    def arm(self) -> int:
        board = self.board
        if board.armed:
            return MAV_RESULT_ACCEPTED
        if not board.settled():
            board.status(MAV_SEVERITY_CRITICAL, "Arming denied: estimator not settled")
            return MAV_RESULT_DENIED
        if self.mode in (FlightMode.POSCTL, FlightMode.MANUAL) and board.health.manual_control_fresh(board.now_us) \
                and board.health.manual.throttle > THROTTLE_ABOVE_CENTER:
            board.status(MAV_SEVERITY_CRITICAL, "Arming denied: throttle above center")
            return MAV_RESULT_TEMPORARILY_REJECTED
        if not self.can_arm():
            if self._needs_data_link():
                board.status(MAV_SEVERITY_WARNING, "Preflight Fail: No connection to the ground control station")
            board.status(MAV_SEVERITY_CRITICAL, "Arming denied: Resolve system health failures first")
            return MAV_RESULT_TEMPORARILY_REJECTED
        board.arm()
        return MAV_RESULT_ACCEPTED

    def can_arm(self) -> bool:
        """PX4's arming checks the emulator has besides the estimator's: the mode, the data link when NAV_DLL_ACT
        wants one, a battery not yet critical (HealthAndArmingChecks: modeCheck, rcAndDataLinkCheck, batteryCheck)."""
        if self._needs_data_link() or self.board.health.battery_warning in ("critical", "emergency"):
            return False
        return self.mode not in PREVENTS_ARMING and self.can_run(self.mode)

    def _needs_data_link(self) -> bool:
        return bool(self.board.params["NAV_DLL_ACT"]) and self.board.health.gcs_lost

    # --- commands ----------------------------------------------------------------------------------------
    def _takeoff(self, command: Command) -> int:
        altitude = command.params[6]
        self.board.navigator.takeoff_alt_amsl = altitude if math.isfinite(altitude) else None
        return self.change_mode(FlightMode.AUTO_TAKEOFF, command.source[1])

    def _land(self, command: Command) -> int:
        result = self.change_mode(FlightMode.AUTO_LAND, command.source[1])
        if result == MAV_RESULT_ACCEPTED:
            self.board.status(MAV_SEVERITY_INFO, "Landing at current position")
        return result

    def _return(self, command: Command) -> int:
        result = self.change_mode(FlightMode.AUTO_RTL, command.source[1])
        if result == MAV_RESULT_ACCEPTED:
            self.board.status(MAV_SEVERITY_INFO, "Returning to launch")
        return result

    def _set_mode(self, command: Command) -> int:
        base, main, sub = (int(p) for p in command.params[:3])
        mode = mode_from_set_mode(base, main, sub)
        if mode is None:
            if main == PX4_MAIN_MODE_AUTO and base & codec.MODE_FLAG_CUSTOM:
                self.board.status(MAV_SEVERITY_CRITICAL, "Unsupported auto mode")
            return MAV_RESULT_TEMPORARILY_REJECTED
        return self.change_mode(mode, command.source[1])

    def _mission_start(self, command: Command) -> int:
        board = self.board
        if not board.missions.items:
            board.status(MAV_SEVERITY_CRITICAL, "Mission start denied! No valid mission")
            return MAV_RESULT_DENIED
        first = command.params[0]
        if not (math.isfinite(first) and -1 <= first < len(board.missions.items)):
            return MAV_RESULT_DENIED
        if first >= 0:
            board.missions.set_current(int(first))
        if self.change_mode(FlightMode.AUTO_MISSION, command.source[1]) != MAV_RESULT_ACCEPTED or \
                self.arm() != MAV_RESULT_ACCEPTED:
            return MAV_RESULT_TEMPORARILY_REJECTED
        return MAV_RESULT_ACCEPTED

    def _set_mission_current(self, command: Command) -> int:
        seq = command.params[0]
        return MAV_RESULT_ACCEPTED if math.isfinite(seq) and self.board.missions.set_current(int(seq)) \
            else MAV_RESULT_DENIED

    def _change_speed(self, command: Command) -> int:
        speed = command.params[1]
        self.board.navigator.cruise_speed = speed if speed > 0 else None
        return MAV_RESULT_ACCEPTED

    def _reposition(self, command: Command) -> int:
        """DO_REPOSITION with its mode-switch flag: AUTO.LOITER at the given place (NaN: where it is)."""
        flags = int(command.params[1]) if math.isfinite(command.params[1]) else 0
        if flags != 1:
            return MAV_RESULT_UNSUPPORTED
        result = self.change_mode(FlightMode.AUTO_LOITER, command.source[1])
        if result == MAV_RESULT_ACCEPTED and self.board.armed:
            self.board.reposition(command.params[4], command.params[5], command.params[6])
        return result
