"""Failsafes, as PX4 v1.15.4's commander failsafe framework reacts (commander/failsafe/failsafe.cpp,
framework.cpp), checked at the navigator's rate while armed.

Each failing condition raises an action; the worst one is taken. An action raised by a condition (not a mode
fallback) first holds COM_FAIL_ACT_T seconds ("Failsafe activated: entering Hold for 5 seconds"), then acts
("Failsafe activated"); an action whose mode cannot run falls through to the next (position control → hold →
return → land → descend → terminate). A return raised by a lost link stays until the user changes mode; the others
end when their condition clears, and the vehicle flies the user's mode again. A user's mode change during a hold,
return, land or descent takes over. HEARTBEAT says MAV_STATE_CRITICAL while an action holds.

- Mode fallback: OFFBOARD without a setpoint for COM_OF_LOSS_T → COM_OBL_RC_ACT (0-2 position control, 3 return,
  4 land, 5 hold, 6 terminate, 7 disarm); a user mode that cannot run (the position estimate lost, a mission gone)
  → return, falling through to a blind descent (AUTO.LAND) without a position.
- Manual control lost (no MANUAL_CONTROL for COM_RC_LOSS_T, having had it since arming) → NAV_RCL_ACT (1 hold, 2
  return, 3 land, 5 terminate, 6 disarm), except in the modes COM_RCL_EXCEPT lists (1 mission, 2 hold and
  take-off, 4 offboard).
- Data link lost (no HEARTBEAT of a MAV_TYPE_GCS for COM_DL_LOSS_T) → NAV_DLL_ACT (0 none, as manual control's),
  not in AUTO.LAND.
- Battery (BATTERY_STATUS of the vehicle's battery component): below BAT_LOW_THR a warning, BAT_CRIT_THR
  COM_LOW_BAT_ACT's action (2 land, 3 return), BAT_EMERGEN_THR land (2, 3); 0 warns only.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum
from typing import TYPE_CHECKING

from pymavlink.dialects.v20.common import MAV_SEVERITY_CRITICAL

from firmware_interface.px4_modes import FlightMode

if TYPE_CHECKING:
    from firmware_interface.emulator.firmware import EmulatedBoard


class Action(IntEnum):
    """PX4's failsafe actions, in its order of precedence (framework.h)."""

    NONE = 0
    WARN = 1
    POSCTL = 2  # FallbackPosCtrl (and the altitude and stabilised fallbacks: the emulator flies neither)
    HOLD = 5
    RTL = 6
    LAND = 7
    DESCEND = 8
    DISARM = 9
    TERMINATE = 10


ACTION_MODES = {Action.POSCTL: FlightMode.POSCTL, Action.HOLD: FlightMode.AUTO_LOITER, Action.RTL: FlightMode.AUTO_RTL,
                Action.LAND: FlightMode.AUTO_LAND, Action.DESCEND: FlightMode.AUTO_LAND}
FALL_THROUGH = (Action.POSCTL, Action.HOLD, Action.RTL, Action.LAND, Action.DESCEND, Action.TERMINATE)
OFFBOARD_LOSS = {0: Action.POSCTL, 1: Action.POSCTL, 2: Action.POSCTL, 3: Action.RTL, 4: Action.LAND,
                 5: Action.HOLD, 6: Action.TERMINATE, 7: Action.DISARM}
LINK_LOSS = {1: Action.HOLD, 2: Action.RTL, 3: Action.LAND, 5: Action.TERMINATE, 6: Action.DISARM}  # NAV_RCL/DLL_ACT
TAKEOVER = (Action.HOLD, Action.RTL, Action.LAND, Action.DESCEND)
RCL_EXCEPT = {FlightMode.AUTO_MISSION: 1, FlightMode.AUTO_LOITER: 2, FlightMode.AUTO_TAKEOFF: 2, FlightMode.OFFBOARD: 4}


@dataclass
class Raised:
    """An action a failing condition raised (PX4's ActionOptions)."""

    action: Action
    delayed: bool = True  # PX4's UserTakeoverAllowed::Auto: hold COM_FAIL_ACT_T first
    until_mode_change: bool = False  # PX4's ClearCondition::OnModeChangeOrDisarm
    failing: bool = True


class Failsafes:
    def __init__(self, board: EmulatedBoard) -> None:
        self.board = board
        self.raised: dict[str, Raised] = {}  # by cause
        self.selected = Action.NONE
        self.delay_us = 0  # PX4's _current_delay: the hold before the action
        self.takeover = False
        self.last_us: int | None = None

    # --- what the commander tells ---------------------------------------------------------------------------
    def user_mode_changed(self) -> None:
        for cause in [c for c, r in self.raised.items() if r.until_mode_change]:
            del self.raised[cause]
        if self.selected in TAKEOVER:
            self.takeover = True

    def armed_changed(self) -> None:
        self.raised = {c: r for c, r in self.raised.items() if not r.until_mode_change}
        self.takeover, self.selected, self.delay_us = False, Action.NONE, 0

    # --- at the navigator's rate -----------------------------------------------------------------------------
    def tick(self, t_us: int) -> None:
        elapsed = t_us - self.last_us if self.last_us is not None else 0
        self.last_us = t_us
        self.delay_us = max(self.delay_us - elapsed, 0)
        if not self.board.armed:
            return
        fallback = self._mode_fallback()
        fresh_warning = self._update(self._conditions())
        if self.selected > Action.HOLD or not self.board.commander.can_run(FlightMode.AUTO_LOITER) or self.takeover:
            self.delay_us = 0
        action, delayed = self._select(fallback)
        if action > self.selected or (action is not Action.NONE and fresh_warning):
            self._announce(delayed)
        self.selected = action
        self._apply(action)

    def _conditions(self) -> dict[str, Raised]:
        board, params = self.board, self.board.params
        user = board.commander.user_mode
        found: dict[str, Raised] = {}
        rc_except = int(params["COM_RCL_EXCEPT"]) & RCL_EXCEPT.get(user, 0)
        if board.manual_control_lost() and not rc_except:
            found["manual control"] = _link_loss(int(params["NAV_RCL_ACT"]))
        if params["NAV_DLL_ACT"] and board.gcs_lost and user is not FlightMode.AUTO_LAND:
            found["data link"] = _link_loss(int(params["NAV_DLL_ACT"]))
        battery = board.battery_warning
        if battery:
            found[f"battery {battery}"] = Raised(_battery_action(battery, int(params["COM_LOW_BAT_ACT"])))
        return {cause: raised for cause, raised in found.items() if raised.action is not Action.NONE}

    def _mode_fallback(self) -> Action:
        """The user's mode cannot run: offboard without setpoints by COM_OBL_RC_ACT, anything else a return."""
        commander = self.board.commander
        user = commander.user_mode
        if user is FlightMode.OFFBOARD and not commander.can_run(user):
            return OFFBOARD_LOSS.get(int(self.board.params["COM_OBL_RC_ACT"]), Action.POSCTL)
        return Action.RTL if not commander.can_run(user) else Action.NONE

    def _update(self, failing: dict[str, Raised]) -> bool:
        """Raise new actions and drop cleared ones; True when a new warning needs announcing."""
        for cause, raised in list(self.raised.items()):
            if cause not in failing and not raised.until_mode_change:
                del self.raised[cause]
            else:
                raised.failing = cause in failing
        fresh_warning = False
        for cause, raised in failing.items():
            if cause in self.raised:
                continue
            self.raised[cause] = raised
            if raised.delayed and raised.action > Action.WARN and self.delay_us == 0 \
                    and self.board.params["COM_FAIL_ACT_T"] > 0.1:
                self.delay_us = round(self.board.params["COM_FAIL_ACT_T"] * 1e6)
            fresh_warning |= raised.action is Action.WARN
            if raised.action >= Action.HOLD:
                self.takeover = False
        return fresh_warning

    def _select(self, fallback: Action) -> tuple[Action, bool]:
        """The action flown now, and whether it is the hold before a delayed one."""
        worst = max((r.action for r in self.raised.values()), default=Action.NONE)
        delayed = False
        if self.delay_us > 0 and not self.takeover and Action.WARN < worst < Action.DISARM:
            worst, delayed = Action.HOLD, True
        if self.takeover and worst in TAKEOVER:
            worst = Action.WARN
        action = self._can_take(max(worst, fallback))
        if action is Action.RTL and self.board.commander.user_mode is FlightMode.AUTO_LAND and \
                self.board.commander.can_run(FlightMode.AUTO_LAND):
            action = Action.WARN  # already landing: no return
        return action, delayed and action is Action.HOLD

    def _can_take(self, action: Action) -> Action:
        """PX4's fall through: the action, or the first after it whose mode can run now."""
        if action not in FALL_THROUGH:
            return action
        for candidate in FALL_THROUGH[FALL_THROUGH.index(action):]:
            if candidate is Action.TERMINATE or self._mode_can_run(candidate):
                return candidate
        return Action.TERMINATE

    def _mode_can_run(self, action: Action) -> bool:
        board = self.board
        if action is Action.POSCTL:
            return board.manual_control_fresh() and board.position_ok()
        if action is Action.DESCEND:
            return True  # only the altitude: the barometer
        return board.commander.can_run(ACTION_MODES[action])

    def _announce(self, delayed: bool) -> None:
        if delayed:
            seconds = (self.delay_us + 500_000) // 1_000_000
            self.board.status(MAV_SEVERITY_CRITICAL, f"Failsafe activated: entering Hold for {seconds} seconds")
        else:
            self.board.status(MAV_SEVERITY_CRITICAL, "Failsafe activated")

    def _apply(self, action: Action) -> None:
        board, commander = self.board, self.board.commander
        if action in (Action.TERMINATE, Action.DISARM):
            board.disarm()
        elif action in ACTION_MODES:
            mode, blind = ACTION_MODES[action], action is Action.DESCEND
            if commander.mode is not mode or not commander.failsafe or board.navigator.blind != blind:
                commander.enter(mode, failsafe=True, blind=blind)
        elif commander.failsafe:  # cleared: the user's mode again
            commander.enter(commander.user_mode)

    @property
    def active(self) -> bool:
        return self.selected > Action.WARN


def _link_loss(param: int) -> Raised:
    """NAV_RCL_ACT / NAV_DLL_ACT (failsafe.cpp fromNavDllOrRclActParam)."""
    action = LINK_LOSS.get(param, Action.NONE)
    return Raised(action, delayed=action not in (Action.TERMINATE, Action.DISARM),
                  until_mode_change=action in (Action.RTL, Action.TERMINATE))


def _battery_action(warning: str, low_bat_act: int) -> Action:
    """fromBatteryWarningActParam: COM_LOW_BAT_ACT 2 land, 3 return at critical and land at emergency."""
    if warning == "critical":
        return {2: Action.LAND, 3: Action.RTL}.get(low_bat_act, Action.WARN)
    if warning == "emergency":
        return Action.LAND if low_bat_act in (2, 3) else Action.WARN
    return Action.WARN
