"""Someone else flies (`pilot: external`): QGroundControl, a joystick through it, MAVSDK, MAVROS, pymavlink. The
bench is only the world: it steps the plant, sends the sensors, relays MAVLink, records and judges; it sends the
board no command and no setpoint (only the parameters the simulated sensors need, as a user sets them for the real
ones, before anyone arms).

Phases: preflight (the board's heartbeat and those parameters), waiting (on the ground), mission (in the air, from
take-off: the mission clock the scenario's gusts and faults are timed on), landed (on the ground again, disarmed),
grounded, done. The run ends at `duration_s` of the bench's time, on Ctrl-C, or with `end: landed` once the
vehicle has taken off, landed and been disarmed.
"""

from __future__ import annotations

from enum import StrEnum
from typing import Any

from firmware_interface.board_requests import ParamSet
from hil.loop.pilot import Ask, Decision, PilotView
from hil.pilots.flight_watch import GROUNDED_S, FlightWatch, params_set_text, pending_params

PARAM_RETRY_S = 1.0


class Phase(StrEnum):
    PREFLIGHT = "preflight"
    WAITING = "waiting"
    MISSION = "mission"  # in the air, from take-off: what the flight is judged on
    LANDED = "landed"  # on the ground again and disarmed; someone may take off again (end: duration)
    GROUNDED = "grounded"  # end: landed, the board's clock runs on GROUNDED_S
    DONE = "done"


class ExternalPilot:
    def __init__(self, end: str, duration_s: float, dt_us: int) -> None:
        self.end = end  # "landed" or "duration"
        self.duration_s = duration_s  # on the bench's clock
        self.phase = Phase.PREFLIGHT
        self.watch = FlightWatch(dt_us)
        self._phase_since_s = 0.0
        self._next_ask_s = 0.0
        self._asks: list[Ask] = []
        self._now_s = 0.0
        self.view: PilotView

    def decide(self, view: PilotView) -> Decision | None:
        self.view, self._asks, self._now_s = view, [], view.now_s
        if view.now_s >= self.duration_s:
            view.emit(f"duration_s = {self.duration_s:g} s reached: the run ends")
            self.phase = Phase.DONE
            return None
        if self.phase is not Phase.PREFLIGHT:
            self.watch.follow(view)
        self._handlers[self.phase](view.now_s)
        if self.phase is Phase.DONE:
            return None
        decision = Decision(str(self.phase), None, self.watch.mission_t, self.phase is Phase.MISSION,
                            tuple(self._asks), self.watch.board_offset_ned)
        self.watch.tick()
        return decision

    def progress(self) -> float:
        return min(self._now_s / self.duration_s, 1.0)

    def summary(self) -> dict[str, Any]:
        figures: dict[str, Any] = {"phase_reached": str(self.phase)}
        if self.watch.board_offset_ned is not None:
            figures["board_frame_offset_m"] = [float(v) for v in self.watch.board_offset_ned]
        return figures

    @property
    def _handlers(self) -> dict[Phase, Any]:
        return {Phase.PREFLIGHT: self._preflight, Phase.WAITING: self._on_the_ground, Phase.MISSION: self._in_the_air,
                Phase.LANDED: self._on_the_ground, Phase.GROUNDED: self._grounded}

    def _switch(self, phase: Phase, now_s: float) -> None:
        self.view.emit(f"phase {self.phase} -> {phase} at {now_s:.3f} s")
        self.phase, self._phase_since_s = phase, now_s

    def _preflight(self, now_s: float) -> None:
        if self.view.board.info is None:
            return
        pending = pending_params(self.view)
        if not pending:
            if self.view.params_owed:
                self.view.emit(params_set_text(self.view.params_owed))
            self.view.emit("the board is ready for its pilot: the bench commands nothing from here on")
            self._switch(Phase.WAITING, now_s)
        elif now_s >= self._next_ask_s:
            self._asks += [ParamSet(name, value) for name, value in pending.items()]
            self._next_ask_s = now_s + PARAM_RETRY_S

    def _on_the_ground(self, now_s: float) -> None:
        if self.watch.airborne:
            self._switch(Phase.MISSION, now_s)

    def _in_the_air(self, now_s: float) -> None:
        if self.watch.landed_and_disarmed(self.view):
            self.view.emit(f"landed and disarmed at {now_s:.3f} s (mission time {self.watch.mission_t:.2f} s)")
            self._switch(Phase.GROUNDED if self.end == "landed" else Phase.LANDED, now_s)

    def _grounded(self, now_s: float) -> None:
        """Simulated time runs on a little after the disarm: PX4 closes its flight log on a disarm it has to see."""
        if now_s - self._phase_since_s >= GROUNDED_S:
            self._switch(Phase.DONE, now_s)
