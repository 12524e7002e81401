"""A person with sticks (`pilot: sticks`): the bench does what such a pilot does at the ground station before
flying — selects Position mode (POSCTL) and arms — and from then on commands nothing: the scenario's
`manual_control:` sticks, sent as a ground station's joystick sends MANUAL_CONTROL (`hil.loop.senders`), fly the
take-off, the flight and the landing, and the board's failsafes do what they do when the sticks stop.

The mission clock starts at arming (the sticks fly from there, take-off included): the sticks' expressions, their
loss windows and the scenario's other events are timed on it. Phases: preflight (the board's heartbeat and the
parameters the bench owes it), mode (POSCTL asked until the board flies it), arming, mission (from arming),
grounded (landed and disarmed), done.
"""

from __future__ import annotations

from enum import StrEnum
from typing import Any

from pymavlink.dialects.v20.common import MAV_CMD_DO_SET_MODE, MAV_RESULT_ACCEPTED

from firmware_interface import hil_codec as codec
from firmware_interface.board_requests import ARM, ParamSet, Request
from firmware_interface.px4_modes import PX4_MAIN_MODE_POSCTL, FlightMode
from hil.exit_codes import EXIT_BOARD, EXIT_EXPECT_FAILED
from hil.loop.pilot import Ask, Decision, PilotView, RunAborted
from hil.pilots.flight_watch import GROUNDED_S, FlightWatch, params_set_text, pending_params

PREFLIGHT_TIMEOUT_S = 60.0  # simulated, from the start: in POSCTL and armed by then (PX4's GNSS checks take ~10 s)
RETRY_S = 1.0  # a parameter, the mode or the arming asked again until the board takes it
POSCTL = Request(MAV_CMD_DO_SET_MODE, (float(codec.MODE_FLAG_CUSTOM), float(PX4_MAIN_MODE_POSCTL)))


class Phase(StrEnum):
    PREFLIGHT = "preflight"
    MODE = "mode"
    ARMING = "arming"
    MISSION = "mission"  # from arming: the sticks fly
    GROUNDED = "grounded"
    DONE = "done"


class SticksPilot:
    def __init__(self, end: str, duration_s: float, dt_us: int) -> None:
        self.end = end  # "landed" (taken off, landed and disarmed) or "duration"
        self.duration_s = duration_s  # on the mission clock, from arming
        self.phase = Phase.PREFLIGHT
        self.watch = FlightWatch(dt_us)
        self.flew = False  # the vehicle has been in the air with the board's heartbeat saying armed
        self._phase_since_s = 0.0
        self._next_ask_s = 0.0
        self._asks: list[Ask] = []
        self.view: PilotView

    def decide(self, view: PilotView) -> Decision | None:
        self.view, self._asks = view, []
        if self.phase is Phase.MISSION or self.phase is Phase.GROUNDED:
            self.watch.follow(view)
        self._handlers[self.phase](view.now_s)
        if self.phase is Phase.DONE:
            return None
        decision = Decision(str(self.phase), None, self.watch.mission_t, self.phase is Phase.MISSION,
                            tuple(self._asks), self.watch.board_offset_ned)
        self.watch.tick()
        return decision

    def progress(self) -> float:
        return min(max(self.watch.mission_t, 0.0) / self.duration_s, 1.0)

    def summary(self) -> dict[str, Any]:
        figures: dict[str, Any] = {"phase_reached": str(self.phase)}
        if self.watch.board_offset_ned is not None:
            figures["board_frame_offset_m"] = [float(v) for v in self.watch.board_offset_ned]
        return figures

    @property
    def _handlers(self) -> dict[Phase, Any]:
        return {Phase.PREFLIGHT: self._preflight, Phase.MODE: self._mode, Phase.ARMING: self._arming,
                Phase.MISSION: self._mission, Phase.GROUNDED: self._grounded}

    def _switch(self, phase: Phase, now_s: float) -> None:
        self.view.emit(f"phase {self.phase} -> {phase} at {now_s:.3f} s")
        self.phase, self._phase_since_s, self._next_ask_s = phase, now_s, now_s

    def _ask_every(self, now_s: float, *asks: Ask) -> None:
        if now_s >= self._next_ask_s:
            self._asks += asks
            self._next_ask_s = now_s + RETRY_S

    def _too_late(self, now_s: float, what: str, request: Request) -> None:
        if now_s > PREFLIGHT_TIMEOUT_S:
            texts = self.view.texts(3)
            result = self.view.board.acks.get(request.command)
            raise RunAborted(f"the board did not {what} within {PREFLIGHT_TIMEOUT_S:g} s (MAV_RESULT {result})"
                             f"{': ' + texts if texts else ''}", EXIT_BOARD)

    def _preflight(self, now_s: float) -> None:
        if self.view.board.info is None:
            self._too_late(now_s, "send a heartbeat", POSCTL)
            return
        pending = pending_params(self.view)
        if pending:
            self._ask_every(now_s, *(ParamSet(name, value) for name, value in pending.items()))
            return
        if self.view.params_owed:
            self.view.emit(params_set_text(self.view.params_owed))
        self._switch(Phase.MODE, now_s)

    def _mode(self, now_s: float) -> None:
        if self.view.board.custom_mode == FlightMode.POSCTL:
            self._switch(Phase.ARMING, now_s)
            return
        self._too_late(now_s, "switch to POSCTL", POSCTL)
        self._ask_every(now_s, POSCTL)

    def _arming(self, now_s: float) -> None:
        if self.view.board.acks.get(ARM.command) == MAV_RESULT_ACCEPTED:
            self.watch.mission_us = 0
            self.view.emit(f"armed in POSCTL at {now_s:.3f} s: the sticks fly, the mission clock starts")
            self._switch(Phase.MISSION, now_s)
            return
        self._too_late(now_s, "arm in POSCTL", ARM)
        self._ask_every(now_s, ARM)

    def _mission(self, now_s: float) -> None:
        self.flew = self.flew or (self.watch.airborne and self.view.board.armed)  # its heartbeat said armed in the air
        if self.flew and self.watch.landed_and_disarmed(self.view):
            self.view.emit(f"landed and disarmed at {now_s:.3f} s (mission time {self.watch.mission_t:.2f} s)")
            self._switch(Phase.GROUNDED, now_s)
        elif self.watch.mission_t > self.duration_s:
            if self.end == "landed":
                raise RunAborted(f"the sticks did not land the vehicle within duration_s = {self.duration_s:g} s of "
                                 f"arming{'' if self.flew else ': it never took off'}", EXIT_EXPECT_FAILED)
            self.view.emit(f"duration_s = {self.duration_s:g} s reached: the run ends")
            self.phase = Phase.DONE

    def _grounded(self, now_s: float) -> None:
        """Simulated time runs on a little after the disarm: PX4 closes its flight log on a disarm it has to see."""
        if now_s - self._phase_since_s >= GROUNDED_S:
            self._switch(Phase.DONE, now_s)
