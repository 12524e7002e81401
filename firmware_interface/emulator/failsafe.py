"""Failsafes, as PX4 v1.15.4's commander failsafe framework reacts (commander/failsafe/failsafe.cpp,
framework.cpp): a condition picks an action; an action whose mode cannot run falls through to the next one
(position control → hold → return → land → terminate); the reaction is announced "Failsafe activated" and the
board reports MAV_STATE_CRITICAL while it holds. Checked at the navigator's rate.

- Offboard loss: in OFFBOARD, no setpoint for COM_OF_LOSS_T → COM_OBL_RC_ACT (0 position, 1 altitude, 2 manual:
  POSCTL with stick input, else hold; 3 return; 4 land; 5 hold; 6 terminate; 7 disarm).
"""

from __future__ import annotations

from enum import IntEnum
from typing import TYPE_CHECKING

from pymavlink.dialects.v20.common import MAV_SEVERITY_CRITICAL

from firmware_interface.px4_modes import FlightMode

if TYPE_CHECKING:
    from firmware_interface.emulator.firmware import EmulatedBoard


class Action(IntEnum):
    """PX4's failsafe actions in its order of severity."""

    NONE = 0
    WARN = 1
    POSCTL = 2  # FallbackPosCtrl (and the altitude and stabilised fallbacks, which the emulator does not fly)
    HOLD = 3
    RTL = 4
    LAND = 5
    TERMINATE = 6
    DISARM = 7


ACTION_MODES = {Action.POSCTL: FlightMode.POSCTL, Action.HOLD: FlightMode.AUTO_LOITER,
                Action.RTL: FlightMode.AUTO_RTL, Action.LAND: FlightMode.AUTO_LAND}
OFFBOARD_LOSS_ACTIONS = {0: Action.POSCTL, 1: Action.POSCTL, 2: Action.POSCTL, 3: Action.RTL, 4: Action.LAND,
                         5: Action.HOLD, 6: Action.TERMINATE, 7: Action.DISARM}


class Failsafes:
    def __init__(self, board: EmulatedBoard) -> None:
        self.board = board

    def tick(self, t_us: int) -> None:
        board = self.board
        if not board.armed:
            return
        commander = board.commander
        if commander.mode is FlightMode.OFFBOARD and not commander.can_run(FlightMode.OFFBOARD):
            self.act(OFFBOARD_LOSS_ACTIONS.get(int(board.params["COM_OBL_RC_ACT"]), Action.POSCTL))

    def act(self, action: Action) -> None:
        """Take `action`, or the first after it whose mode can run now."""
        board = self.board
        while action in ACTION_MODES and not self._can_take(action):
            action = Action(action + 1)
        if action is Action.NONE:
            return
        board.status(MAV_SEVERITY_CRITICAL, "Failsafe activated")
        if action in ACTION_MODES:
            board.commander.enter(ACTION_MODES[action], failsafe=True)
        elif action in (Action.TERMINATE, Action.DISARM):
            board.disarm()

    def _can_take(self, action: Action) -> bool:
        board = self.board
        if action is Action.POSCTL and not board.manual_control_fresh():
            return False
        return board.commander.can_run(ACTION_MODES[action])
