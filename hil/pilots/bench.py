"""The bench flies the vehicle itself (`pilot: bench`): it arms the board, switches it to offboard, streams the
scenario's reference as setpoints, and lands.

Phases: preflight (on the ground until the board accepts arming), offboard (switch, holding the ground point),
takeoff (climb to the reference's start, t < 0), mission (the reference, 0 ≤ t ≤ duration), landing or disarming,
grounded, done. The mission clock counts integer µs like the bench's, so it never drifts from it.
"""

from __future__ import annotations

import math
from enum import StrEnum
from typing import Any

import numpy as np
from pymavlink.dialects.v20.common import MAV_RESULT_ACCEPTED

from firmware_interface.board_requests import ARM, DISARM, FORCE_DISARM, LAND, OFFBOARD, ParamSet, Request
from hil.exit_codes import EXIT_BOARD, EXIT_EXPECT_FAILED
from hil.judge.flight_judge import FlightFailed, FlightJudge
from hil.loop.pilot import Ask, Decision, PilotView, RunAborted
from hil.pilots.flight_watch import (
    DISARMED_IN_FLIGHT_S,
    GROUNDED_S,
    LANDED_HEIGHT_M,
    board_frame_offset,
    board_landed,
    params_set_text,
    pending_params,
)
from hil.scenario.mission import MissionPlan
from hil.scenario.reference import RefSample

PREFLIGHT_TIMEOUT_S = 60.0  # simulated: PX4's GNSS checks alone need ~10 s of good data
ARM_RETRY_S = 1.0
OFFBOARD_TIMEOUT_S = 5.0
SETPOINTS_BEFORE_OFFBOARD_S = 0.2  # PX4 refuses offboard until setpoints are streaming
LAND_RETRY_S = 1.0
LANDING_TIMEOUT_S = 60.0  # from the land request to a confirmed disarm
DISARM_AFTER_LANDED_S = 3.0  # PX4 disarms by itself 2 s after landing (COM_DISARM_LAND); ask after this
DISARM_TIMEOUT_S = 5.0  # `end: disarm`: the forced disarm must be confirmed within this


class Phase(StrEnum):
    """The bench pilot's phases, in flight order (the values are what the recording says)."""

    PREFLIGHT = "preflight"  # on the ground until the board accepts arming
    OFFBOARD = "offboard"  # armed, streaming the ground point until offboard is accepted
    TAKEOFF = "takeoff"  # climbing to the reference's start (mission time < 0)
    MISSION = "mission"  # the reference, 0 ≤ t ≤ duration
    LANDING = "landing"  # the board's own land mode until it reports landed and disarmed
    DISARMING = "disarming"  # `end: disarm`: a forced disarm where the vehicle is
    GROUNDED = "grounded"  # landed and disarmed; the board's clock runs on GROUNDED_S
    DONE = "done"


FLYING = (Phase.TAKEOFF, Phase.MISSION, Phase.LANDING, Phase.DISARMING)


class BenchPilot:
    def __init__(self, plan: MissionPlan, end: str, dt_us: int) -> None:
        self.plan = plan
        self.end = end  # "land" or "disarm" once the mission is flown
        self.dt_us = dt_us
        self.phase = Phase.PREFLIGHT
        self.judge = FlightJudge()
        self.board_offset_ned: np.ndarray | None = None  # board local frame - truth, from arming on
        self._mission_us: int | None = None  # the mission clock; None before take-off
        self.mission_t = -math.inf  # the same in seconds, what the reference and the environment are sampled at
        self._phase_since_s = 0.0
        self._next_request_s = 0.0
        self._landed_since_s: float | None = None
        self._disarmed_in_flight_since: float | None = None
        self._params_reported = False
        self._asks: list[Ask] = []
        self.view: PilotView  # the latest, while deciding
        self._handlers = self._phase_handlers()  # built once: the bench's step waits for every decision

    # --- the contract ---------------------------------------------------------------
    def decide(self, view: PilotView) -> Decision | None:
        self.view, self._asks = view, []
        reference = self._handlers[self.phase](view.now_s)
        if self.phase is Phase.DONE:
            return None
        flying = self.phase in FLYING
        decision = Decision(str(self.phase), reference, self.mission_t, flying, tuple(self._asks),
                            self.board_offset_ned)
        if flying:  # this step is flown on the mission clock: it moves on with the bench's
            assert self._mission_us is not None
            self._mission_us += self.dt_us
            self.mission_t = self._mission_us / 1e6
        return decision

    def progress(self) -> float:
        total_s = self.plan.takeoff_s + self.plan.duration_s
        return min(max(self.mission_t + self.plan.takeoff_s, 0.0), total_s) / total_s

    def summary(self) -> dict[str, Any]:
        figures: dict[str, Any] = {"phase_reached": str(self.phase)}
        if self.board_offset_ned is not None:
            figures["board_frame_offset_m"] = [float(v) for v in self.board_offset_ned]
        return figures

    def _phase_handlers(self) -> dict[Phase, Any]:
        return {Phase.PREFLIGHT: self._preflight, Phase.OFFBOARD: self._offboard, Phase.TAKEOFF: self._takeoff,
                Phase.MISSION: self._mission, Phase.LANDING: self._landing, Phase.DISARMING: self._disarming,
                Phase.GROUNDED: self._grounded}

    # --- helpers --------------------------------------------------------------------
    def when(self) -> str:
        if math.isfinite(self.mission_t):
            return f"at mission time {self.mission_t:.2f} s"
        return f"at bench time {self.view.now_s:.2f} s (before the mission)"

    def _request_every(self, now_s: float, period_s: float, request: Request) -> None:
        """Ask now and again every `period_s` until its ACK arrives (the ACK is read per step)."""
        if now_s >= self._next_request_s:
            self._asks.append(request)
            self._next_request_s = now_s + period_s

    def _switch(self, phase: Phase, now_s: float) -> None:
        self.view.emit(f"phase {self.phase} -> {phase} at {now_s:.3f} s")
        self.phase = phase
        self._phase_since_s = now_s
        self._next_request_s = now_s

    # --- phases: each returns the reference to fly this step (None: no setpoint) ------
    def _preflight(self, now_s: float) -> RefSample | None:
        board = self.view.board
        if now_s > PREFLIGHT_TIMEOUT_S:
            if board.info is None:
                raise RunAborted(f"no heartbeat from the board on {self.view.command_link} within "
                                 f"{PREFLIGHT_TIMEOUT_S:g} s of stepping", EXIT_BOARD)
            raise RunAborted(f"board did not arm within {PREFLIGHT_TIMEOUT_S:g} s: "
                             f"{self.view.texts(3) or 'no reason given'}", EXIT_BOARD)
        if board.info is None:
            return None  # PX4 SITL opens its MAVLink ports only as its clock runs: keep stepping
        if not self._board_params_set(now_s):
            return None
        if board.acks.get(ARM.command) == MAV_RESULT_ACCEPTED:
            self._align_board_frame()
            self._switch(Phase.OFFBOARD, now_s)
            self._next_request_s = now_s + SETPOINTS_BEFORE_OFFBOARD_S
        else:
            self._request_every(now_s, ARM_RETRY_S, ARM)
        return None if self.phase is Phase.PREFLIGHT else self.plan.sample(-self.plan.takeoff_s)

    def _board_params_set(self, now_s: float) -> bool:
        """The parameters the bench owes the board, set and read back before arming; True once all are confirmed."""
        pending = pending_params(self.view)
        if not pending:
            if self.view.params_owed and not self._params_reported:
                self._params_reported = True
                self.view.emit(params_set_text(self.view.params_owed))
            return True
        if now_s >= self._next_request_s:
            self._asks += [ParamSet(name, value) for name, value in pending.items()]
            self._next_request_s = now_s + ARM_RETRY_S
        return False

    def _align_board_frame(self) -> None:
        """Setpoints go to the board in its own local frame, taken when it accepts arming (on the ground, at rest)
        and kept for the run."""
        self.board_offset_ned = board_frame_offset(self.view)

    def _offboard(self, now_s: float) -> RefSample | None:
        ack = self.view.board.acks.get(OFFBOARD.command)
        if ack == MAV_RESULT_ACCEPTED:
            self._switch(Phase.TAKEOFF, now_s)
            self._mission_us = -round(self.plan.takeoff_s * 1e6)
            self.mission_t = self._mission_us / 1e6
        elif now_s - self._phase_since_s > OFFBOARD_TIMEOUT_S:
            texts = self.view.texts(2)
            raise RunAborted(f"offboard mode refused (MAV_RESULT {ack}){': ' + texts if texts else ''}", EXIT_BOARD)
        else:
            self._request_every(now_s, 0.5, OFFBOARD)
        return self.plan.sample(self.mission_t if self.phase is Phase.TAKEOFF else -self.plan.takeoff_s)

    def _judge_armed(self, now_s: float) -> None:
        """A board that disarms in flight (a failsafe, a crash detector) ends the run: it would fall."""
        if self.view.outputs_armed:
            self._disarmed_in_flight_since = None
            return
        if self._disarmed_in_flight_since is None:
            self._disarmed_in_flight_since = now_s
        elif now_s - self._disarmed_in_flight_since > DISARMED_IN_FLIGHT_S:
            texts = self.view.texts(2)
            raise RunAborted(f"the board disarmed in flight at {self._disarmed_in_flight_since:.3f} s (mission time "
                             f"{self.mission_t:.2f} s){': ' + texts if texts else ''}", EXIT_EXPECT_FAILED)

    def _judge_flight(self) -> None:
        """Leaving the ground, hitting it, tumbling: judged on the true state (events, then the end)."""
        state = self.view.truth
        assert state is not None
        height, roll, pitch = -float(state.pos_ned[2]), float(state.rpy[0]), float(state.rpy[1])
        step = self.judge.mission_step if self.phase is Phase.MISSION else self.judge.take_off_step
        try:
            step(height, state.on_ground, roll, pitch, self.when)
        except FlightFailed as exc:
            self.view.emit(str(exc))
            raise RunAborted(str(exc), EXIT_EXPECT_FAILED) from exc

    def _takeoff(self, now_s: float) -> RefSample | None:
        self._judge_armed(now_s)
        self._judge_flight()
        if self.mission_t >= 0:
            self._switch(Phase.MISSION, now_s)
        return self.plan.sample(self.mission_t)

    def _mission(self, now_s: float) -> RefSample | None:
        self._judge_armed(now_s)
        self._judge_flight()
        if self.mission_t <= self.plan.duration_s:
            return self.plan.sample(self.mission_t)
        self._switch(Phase.DISARMING if self.end == "disarm" else Phase.LANDING, now_s)
        return self._end_point()

    def _end_point(self) -> RefSample:
        return self.plan.sample(self.plan.duration_s)

    def _landing(self, now_s: float) -> RefSample | None:
        """The board lands by itself (PX4's land mode); done once it reports landed and disarmed."""
        board = self.view.board
        if now_s - self._phase_since_s > LANDING_TIMEOUT_S:
            extended = board.latest.get("EXTENDED_SYS_STATE")
            landed = "no EXTENDED_SYS_STATE" if extended is None else f"landed_state {extended.landed_state}"
            texts = self.view.texts(2)
            raise RunAborted(f"landing timed out after {LANDING_TIMEOUT_S:g} s: board reports {landed}, "
                             f"{'armed' if board.armed else 'disarmed'}{'; ' + texts if texts else ''}",
                             EXIT_EXPECT_FAILED)
        if board.acks.get(LAND.command) != MAV_RESULT_ACCEPTED:
            self._request_every(now_s, LAND_RETRY_S, LAND)
            return self._end_point()  # keep offboard fed until the board has switched to landing
        if not board_landed(self.view):
            self._landed_since_s = None
            return None
        if self._landed_since_s is None:
            self._landed_since_s = now_s
            self.view.emit(f"board reports landed at {now_s:.3f} s")
        if not board.armed:
            self._finish_on_ground(now_s)
        elif now_s - self._landed_since_s > DISARM_AFTER_LANDED_S:
            self._request_every(now_s, 1.0, DISARM)
        return None


    def _finish_on_ground(self, now_s: float) -> None:
        assert self.view.truth is not None
        height = -float(self.view.truth.pos_ned[2])
        if height > LANDED_HEIGHT_M:
            raise RunAborted(f"the board reported landed and disarmed at {now_s:.3f} s with the vehicle "
                             f"{height:.2f} m above the ground", EXIT_EXPECT_FAILED)
        self.view.emit(f"disarmed on the ground at {now_s:.3f} s")
        self._switch(Phase.GROUNDED, now_s)

    def _grounded(self, now_s: float) -> RefSample | None:
        """Simulated time runs on a little after the disarm: in lockstep the board's logger only writes as its
        clock advances, and PX4's (SDLOG_MODE 1) closes its log on the disarm it has yet to see."""
        if now_s - self._phase_since_s >= GROUNDED_S:
            self._switch(Phase.DONE, now_s)
        return None

    def _disarming(self, now_s: float) -> RefSample | None:
        confirmed = self.view.board.acks.get(ARM.command) == MAV_RESULT_ACCEPTED or not self.view.outputs_armed
        if confirmed and now_s > self._phase_since_s:
            self.view.emit(f"disarmed at {now_s:.3f} s (end: disarm)")
            self._switch(Phase.DONE, now_s)
            return None
        if now_s - self._phase_since_s > DISARM_TIMEOUT_S:
            raise RunAborted(f"disarm not confirmed within {DISARM_TIMEOUT_S:g} s: {self.view.texts(2)}",
                             EXIT_EXPECT_FAILED)
        self._request_every(now_s, 0.5, FORCE_DISARM)
        return self._end_point()
