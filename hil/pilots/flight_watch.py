"""What every pilot watches: the parameters the bench owes the board, the board's local frame against the truth,
and, when the board flies by itself (a mission, an outside pilot), the flight as the truth and the board's reports
show it: take-off (the mission clock starts), a disarm or a tumble in the air, landing and the disarm after it."""

from __future__ import annotations

import math

import numpy as np
from pymavlink.dialects.v20.common import MAV_LANDED_STATE_ON_GROUND

from hil.exit_codes import EXIT_EXPECT_FAILED
from hil.judge.flight_judge import LIFTOFF_M, FlightFailed, FlightJudge
from hil.loop.pilot import PilotView, RunAborted

LANDED_HEIGHT_M = 0.2  # the board says landed: the true vehicle must be this close to the ground
DISARMED_IN_FLIGHT_S = 0.25  # the board's outputs say disarmed this long during take-off or the mission
GROUNDED_S = 1.0  # stepping on after the disarm, so the board's own flight log records it before it is stopped


def pending_params(view: PilotView) -> dict[str, float]:
    """The parameters the bench owes the board (e.g. EKF2_GPS_DELAY for the simulated receiver) that it has not
    read back at their value yet."""
    read_back = view.board.params
    return {name: value for name, value in view.params_owed.items()
            if read_back.get(name) is None or abs(read_back[name] - value) > 1e-3 * max(abs(value), 1)}


def params_set_text(owed: dict[str, float]) -> str:
    return "board parameters set: " + ", ".join(f"{n} = {v:g}" for n, v in owed.items())


def board_frame_offset(view: PilotView) -> np.ndarray:
    """The board's local frame against the truth (its LOCAL_POSITION_NED - the true position), taken on the
    ground at rest and kept for the run; an event says it. Zero when the board has sent no position."""
    local = view.board.latest.get("LOCAL_POSITION_NED")
    truth = view.truth.pos_ned if view.truth is not None else np.zeros(3)
    if local is None:
        view.emit("board sent no LOCAL_POSITION_NED before arming: setpoints in the bench's frame")
        return np.zeros(3)
    offset = np.array((local.x, local.y, local.z)) - truth
    view.emit("board frame: local origin offset [{:+.3f}, {:+.3f}, {:+.3f}] m (board - truth)".format(*offset))
    return offset


def board_landed(view: PilotView) -> bool:
    extended = view.board.latest.get("EXTENDED_SYS_STATE")
    return extended is not None and extended.landed_state == MAV_LANDED_STATE_ON_GROUND


class FlightWatch:
    """A flight the board flies by itself, followed step by step: the mission clock from take-off (integer µs, as
    the bench's), the checks that end a flight gone wrong, and its landing."""

    def __init__(self, dt_us: int) -> None:
        self.dt_us = dt_us
        self.mission_us: int | None = None  # None before take-off
        self.airborne = False  # the true vehicle is above LIFTOFF_M
        self.board_offset_ned: np.ndarray | None = None  # from the board's first armed heartbeat on
        self._judge = FlightJudge()
        self._disarmed_in_air_since: float | None = None

    @property
    def mission_t(self) -> float:
        return -math.inf if self.mission_us is None else self.mission_us / 1e6

    @property
    def took_off(self) -> bool:
        return self.mission_us is not None

    def when(self, now_s: float) -> str:
        return (f"at mission time {self.mission_t:.2f} s" if self.took_off
                else f"at bench time {now_s:.2f} s (before take-off)")

    def follow(self, view: PilotView) -> None:
        """This step's truth and reports: take-off, the frame offset at arming, a disarm or a tumble in the air
        (RunAborted)."""
        if self.board_offset_ned is None and view.board.armed:
            self.board_offset_ned = board_frame_offset(view)
        assert view.truth is not None
        height = -float(view.truth.pos_ned[2])
        self.airborne = height > LIFTOFF_M
        if self.airborne and not self.took_off:
            self.mission_us = 0
            view.emit(f"took off at {view.now_s:.3f} s: the mission clock starts")
        if not self.airborne:
            self._disarmed_in_air_since = None
            return
        try:
            self._judge.tumble_check(float(view.truth.rpy[0]), float(view.truth.rpy[1]),
                                    lambda: self.when(view.now_s))
        except FlightFailed as exc:
            view.emit(str(exc))
            raise RunAborted(str(exc), EXIT_EXPECT_FAILED) from exc
        self._judge_armed(view)

    def _judge_armed(self, view: PilotView) -> None:
        """A board that disarms in the air (a failsafe, a crash detector, a pilot's kill switch) ends the run."""
        if view.outputs_armed:
            self._disarmed_in_air_since = None
            return
        if self._disarmed_in_air_since is None:
            self._disarmed_in_air_since = view.now_s
        elif view.now_s - self._disarmed_in_air_since > DISARMED_IN_FLIGHT_S:
            texts = view.texts(2)
            raise RunAborted(f"the board disarmed in flight at {self._disarmed_in_air_since:.3f} s "
                             f"{self.when(view.now_s)}{': ' + texts if texts else ''}", EXIT_EXPECT_FAILED)

    def landed_and_disarmed(self, view: PilotView) -> bool:
        """After a take-off: the board reports landed and disarmed. A vehicle it calls landed that is still in the
        air is a failed flight (RunAborted)."""
        if not self.took_off or not board_landed(view) or view.board.armed:
            return False
        assert view.truth is not None
        height = -float(view.truth.pos_ned[2])
        if height > LANDED_HEIGHT_M:
            raise RunAborted(f"the board reported landed and disarmed at {view.now_s:.3f} s with the vehicle "
                             f"{height:.2f} m above the ground", EXIT_EXPECT_FAILED)
        return True

    def tick(self) -> None:
        """The step is decided: the mission clock moves on with the bench's."""
        if self.mission_us is not None:
            self.mission_us += self.dt_us
