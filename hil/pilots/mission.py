"""The bench as the ground station that starts a PX4 mission (`pilot: {type: mission, plan: FILE}`): it uploads the
mission with MAVLink's mission protocol, arms, starts it (MAV_CMD_MISSION_START: PX4's AUTO.MISSION), and from then
on only watches. The board's navigator flies the take-off, the legs, the return and the landing; the bench streams
no setpoint and sends no command until the end.

Phases: preflight (the board's heartbeat and the parameters the bench owes it), upload, arming, starting (until the
vehicle leaves the ground), mission (from take-off: the mission clock, on which the scenario's gusts, payload
steps and faults are timed, and `duration_s` is the mission's time limit), grounded (landed and disarmed), done.
"""

from __future__ import annotations

from enum import StrEnum
from typing import Any

from pymavlink.dialects.v20.common import MAV_RESULT_ACCEPTED

from firmware_interface.board_requests import ARM, ParamSet, Request, mission_start
from firmware_interface.px4_modes import mode_name
from hil.exit_codes import EXIT_BOARD, EXIT_EXPECT_FAILED
from hil.judge.mission_progress import MissionProgress
from hil.loop.pilot import Ask, Decision, PilotView, RunAborted
from hil.pilots.flight_watch import GROUNDED_S, FlightWatch, params_set_text, pending_params
from hil.pilots.mission_upload import MissionUpload
from hil.scenario.mission_items import PlanItem, command_name

PREFLIGHT_TIMEOUT_S = 60.0  # simulated, from the start: uploaded and armed by then (PX4's GNSS checks take ~10 s)
RETRY_S = 1.0  # a parameter, the arming or the start asked again until the board acknowledges it
START_TIMEOUT_S = 10.0  # from arming to leaving the ground (PX4 disarms a vehicle idle 10 s: COM_DISARM_PRFLT)


class Phase(StrEnum):
    PREFLIGHT = "preflight"
    UPLOAD = "upload"
    ARMING = "arming"
    STARTING = "starting"
    MISSION = "mission"  # in the air, from take-off: what the flight is judged on
    GROUNDED = "grounded"
    DONE = "done"


class MissionPilot:
    def __init__(self, items: list[PlanItem], duration_s: float, dt_us: int) -> None:
        self.items = items
        self.duration_s = duration_s  # the mission's time limit, from take-off
        self.phase = Phase.PREFLIGHT
        self.watch = FlightWatch(dt_us)
        self.upload = MissionUpload(items)
        self.mission: MissionProgress[float] = MissionProgress(items)  # through the mission, by bench time
        self.mode = ""  # the board's latest mode (HEARTBEAT.custom_mode)
        self._phase_since_s = 0.0
        self._next_ask_s = 0.0
        self._asks: list[Ask] = []
        self.view: PilotView

    # --- the contract ---------------------------------------------------------------
    def decide(self, view: PilotView) -> Decision | None:
        self.view, self._asks = view, []
        self._note_progress(view)
        if self.phase not in (Phase.PREFLIGHT, Phase.UPLOAD):
            self.watch.follow(view)
        self._handlers[self.phase](view.now_s)
        if self.phase is Phase.DONE:
            return None
        decision = Decision(str(self.phase), None, self.watch.mission_t, self.phase is Phase.MISSION,
                            tuple(self._asks), self.watch.board_offset_ned)
        self.watch.tick()
        return decision

    def progress(self) -> float:
        return len(self.mission.reached) / self.mission.count

    def summary(self) -> dict[str, Any]:
        figures: dict[str, Any] = {"phase_reached": str(self.phase)}
        if self.watch.board_offset_ned is not None:
            figures["board_frame_offset_m"] = [float(v) for v in self.watch.board_offset_ned]
        return figures

    @property
    def _handlers(self) -> dict[Phase, Any]:
        return {Phase.PREFLIGHT: self._preflight, Phase.UPLOAD: self._upload, Phase.ARMING: self._arming,
                Phase.STARTING: self._starting, Phase.MISSION: self._mission, Phase.GROUNDED: self._grounded}

    # --- helpers --------------------------------------------------------------------
    def _switch(self, phase: Phase, now_s: float) -> None:
        self.view.emit(f"phase {self.phase} -> {phase} at {now_s:.3f} s")
        self.phase, self._phase_since_s, self._next_ask_s = phase, now_s, now_s

    def _ask_every(self, now_s: float, *asks: Ask) -> None:
        if now_s >= self._next_ask_s:
            self._asks += asks
            self._next_ask_s = now_s + RETRY_S

    def _note_progress(self, view: PilotView) -> None:
        """Items reached and mode changes, as events (`MissionProgress` says what counts as reached)."""
        mission, now_s, before = self.mission, view.now_s, set(self.mission.reached)
        for message in view.messages:
            if message.get_type() == "MISSION_ITEM_REACHED":
                mission.item_reached(message.seq, now_s)
            elif message.get_type() == "MISSION_CURRENT":
                mission.current_item(message.seq, now_s)
        if view.board.custom_mode and (mode := mode_name(view.board.custom_mode)) != self.mode:  # 0: no mode yet
            self.mode = mode
            mission.mode(mode, now_s)
            view.emit(f"board mode {mode} at {now_s:.3f} s")
        for seq in sorted(set(mission.reached) - before):
            view.emit(f"mission item {seq} reached ({command_name(self.items[seq].command)}) "
                      f"{self.watch.when(now_s)}")

    def _refused(self, what: str, request: Request) -> RunAborted:
        texts = self.view.texts(3)
        result = self.view.board.acks.get(request.command)
        return RunAborted(f"{what} (MAV_RESULT {result}){': ' + texts if texts else ''}", EXIT_BOARD)

    # --- phases -----------------------------------------------------------------------
    def _preflight(self, now_s: float) -> None:
        if now_s > PREFLIGHT_TIMEOUT_S:
            raise RunAborted(f"no heartbeat from the board on {self.view.command_link} within "
                             f"{PREFLIGHT_TIMEOUT_S:g} s of stepping", EXIT_BOARD)
        if self.view.board.info is None:
            return
        pending = pending_params(self.view)
        if pending:
            self._ask_every(now_s, *(ParamSet(name, value) for name, value in pending.items()))
            return
        if self.view.params_owed:
            self.view.emit(params_set_text(self.view.params_owed))
        self._switch(Phase.UPLOAD, now_s)

    def _upload(self, now_s: float) -> None:
        self._asks += self.upload.step(now_s, self.view.messages)
        if self.upload.failure is not None:
            raise RunAborted(f"mission upload failed: {self.upload.failure}"
                             f"{'; ' + self.view.texts(2) if self.view.texts(2) else ''}", EXIT_BOARD)
        if self.upload.accepted:
            self.view.emit(f"mission uploaded: {len(self.items)} items accepted by the board")
            self._switch(Phase.ARMING, now_s)

    def _arming(self, now_s: float) -> None:
        if self.view.board.acks.get(ARM.command) == MAV_RESULT_ACCEPTED:
            self._switch(Phase.STARTING, now_s)
        elif now_s > PREFLIGHT_TIMEOUT_S:
            raise self._refused(f"board did not arm within {PREFLIGHT_TIMEOUT_S:g} s", ARM)
        else:
            self._ask_every(now_s, ARM)

    def _starting(self, now_s: float) -> None:
        start = mission_start(len(self.items))
        if self.watch.took_off:
            self._switch(Phase.MISSION, now_s)
        elif now_s - self._phase_since_s > START_TIMEOUT_S:
            started = self.view.board.acks.get(start.command) == MAV_RESULT_ACCEPTED
            raise self._refused("the mission was started but the vehicle never left the ground" if started
                                else "the board did not start the mission", start)
        elif self.view.board.acks.get(start.command) != MAV_RESULT_ACCEPTED:
            self._ask_every(now_s, start)

    def _mission(self, now_s: float) -> None:
        if self.watch.landed_and_disarmed(self.view):
            self.mission.landed(now_s)
            self.view.emit(f"landed and disarmed at {now_s:.3f} s (mission time {self.watch.mission_t:.2f} s)")
            self._switch(Phase.GROUNDED, now_s)
        elif self.watch.mission_t > self.duration_s:
            current = self.view.board.latest.get("MISSION_CURRENT")
            at = f"item {current.seq} of {len(self.items)}" if current is not None else "no MISSION_CURRENT"
            raise RunAborted(f"the mission did not finish within duration_s = {self.duration_s:g} s of take-off: "
                             f"{at}, {len(self.mission.reached)} items reached, mode {self.mode or 'unknown'}",
                             EXIT_EXPECT_FAILED)

    def _grounded(self, now_s: float) -> None:
        """Simulated time runs on a little after the disarm: PX4 closes its flight log on a disarm it has to see."""
        if now_s - self._phase_since_s >= GROUNDED_S:
            self._switch(Phase.DONE, now_s)
