"""A failsafe judged: when its trigger came (from what the bench did: the battery it reported, the sticks or the
ground station it silenced, the GPS it dropped), what the board then flew (its HEARTBEAT's mode, and
MAV_STATE_CRITICAL, which PX4 reports while a failsafe action holds: vehicle_status.failsafe), and where the
vehicle came down (the truth). `expect.failsafe` and `expect.no_failsafe` are decided here.

The reaction to a trigger is the first failsafe mode the board flies after it: AUTO.RTL, AUTO.LAND (PX4's Land and
Descend both report it) or AUTO.LOITER; a hold followed at once by a return or a landing is PX4's COM_FAIL_ACT_T
delay before them, and the reaction is then what follows it."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from pymavlink.dialects.v20.common import MAV_STATE_CRITICAL

from firmware_interface.px4_modes import mode_name
from firmware_interface.vehicle_codec import remaining_percent
from hil.judge.verdict import Moment, Verdict
from hil.loop.frame import StepFrame
from hil.scenario.failsafe import FailsafeExpected, gps_dropouts, joystick_losses, parameter
from hil.scenario.schema import Scenario

ACTION_MODES = {"rtl": "AUTO.RTL", "land": "AUTO.LAND", "hold": "AUTO.LOITER"}
FAILSAFE_MODES = frozenset(ACTION_MODES.values())
HOLD = ACTION_MODES["hold"]


@dataclass
class FailsafeJudge:
    """Fed every step's frame; `verdict` and `figures` at the end."""

    after: str | None  # the trigger an expected failsafe follows (None: only no_failsafe, or nothing, is judged)
    windows: list[tuple[float, float]]  # the trigger's windows on the mission clock (not for "battery low")
    battery_threshold: float  # BAT_CRIT_THR: below it PX4 acts on COM_LOW_BAT_ACT (below BAT_LOW_THR it only warns)
    trigger: Moment | None = None
    trigger_note: str = ""
    modes_after: list[tuple[str, Moment]] = field(default_factory=list)  # the board's mode changes after the trigger
    landed: tuple[Moment, float] | None = None  # disarmed after the trigger, and how far from home (m)
    critical: tuple[Moment, str] | None = None  # first MAV_STATE_CRITICAL while armed, and the mode then
    lowest_percent: int | None = None
    _mode: str = ""
    _armed = False

    def on_step(self, frame: StepFrame) -> None:
        now = Moment(frame.t_us, frame.mission_t)
        if self.trigger is None and self.after is not None:
            self._find_trigger(frame, now)
        for kind, payload in frame.board:
            if kind == "HEARTBEAT" and payload["custom_mode"]:
                self._heartbeat(payload, now)
        if self.trigger is not None and self.landed is None:
            if self._armed and not frame.armed:
                self.landed = (now, float(math.hypot(frame.truth.pos_ned[0], frame.truth.pos_ned[1])))
            self._armed = frame.armed

    def _find_trigger(self, frame: StepFrame, now: Moment) -> None:
        if self.after == "battery low":
            for channel, payload in frame.sent:
                if channel == "battery":
                    percent = remaining_percent(payload["remaining"])
                    self.lowest_percent = percent if self.lowest_percent is None else min(self.lowest_percent, percent)
                    if percent / 100 < self.battery_threshold:
                        self.trigger, self.trigger_note = now, f" (sent {percent} %)"
        elif any(start <= frame.mission_t < end for start, end in self.windows):
            self.trigger = now

    def _heartbeat(self, payload: dict[str, Any], now: Moment) -> None:
        mode = mode_name(payload["custom_mode"])
        if mode != self._mode:
            self._mode = mode
            if self.trigger is not None:
                self.modes_after.append((mode, now))
        if self.critical is None and payload["armed"] and payload["system_status"] == MAV_STATE_CRITICAL:
            self.critical = (now, mode)

    def reaction(self) -> tuple[str, Moment] | None:
        """The failsafe mode the board flew after the trigger (past a hold that only delayed it)."""
        changes = self.modes_after
        for index, (mode, at) in enumerate(changes):
            if mode not in FAILSAFE_MODES:
                continue
            following = changes[index + 1] if index + 1 < len(changes) else None
            if mode == HOLD and following is not None and following[0] in FAILSAFE_MODES - {HOLD}:
                return following
            return mode, at
        return None

    # --- results --------------------------------------------------------------------
    def figures(self) -> dict[str, Any]:
        figures: dict[str, Any] = {"critical_at_mission_s": self.critical[0].clock if self.critical else None}
        if self.after is not None:
            reaction = self.reaction()
            figures |= {"trigger": self.after, "trigger_at_mission_s": self.trigger.clock if self.trigger else None,
                        "modes_after": [[mode, at.clock] for mode, at in self.modes_after],
                        "reaction": reaction[0] if reaction else None,
                        "reaction_at_mission_s": reaction[1].clock if reaction else None,
                        "landed_at_mission_s": self.landed[0].clock if self.landed else None,
                        "landed_from_home_m": self.landed[1] if self.landed else None}
        return figures

    def failsafe_verdict(self, expected: FailsafeExpected, end: Moment) -> Verdict:
        bound = (f"{expected.action} within {expected.within_s:g} s of {expected.after}"
                 + (f", landed within {expected.landed_within_m_of_home:g} m of home"
                    if expected.landed_within_m_of_home is not None else ""))
        if self.trigger is None:
            return Verdict("failsafe", False, self._no_trigger(), bound, end.t_us, end.clock)
        said = f"{expected.after} at {_clock(self.trigger)}{self.trigger_note}"
        reaction = self.reaction()
        if expected.action == "none":
            met = reaction is None or _after_s(self.trigger, reaction[1]) > expected.within_s
            flew = "no failsafe mode" if reaction is None or met else self._flew(reaction)
            found = f"{said}, {flew} within {expected.within_s:g} s"
            return Verdict("failsafe", met, found, bound, end.t_us, end.clock)
        if reaction is None:
            seen = ", ".join(mode for mode, _ in self.modes_after) or "none"
            return Verdict("failsafe", False, f"{said}, the board flew no failsafe mode (modes after it: {seen})",
                           bound, end.t_us, end.clock)
        wanted = ACTION_MODES[expected.action]
        met = reaction[0] == wanted and _after_s(self.trigger, reaction[1]) <= expected.within_s
        found = f"{said}, {self._flew(reaction)}" + ("" if reaction[0] == wanted else f" instead of {wanted}")
        decided = reaction[1]
        if expected.landed_within_m_of_home is not None:
            if self.landed is None:
                met, found = False, found + ", never landed and disarmed"
            else:
                met = met and self.landed[1] <= expected.landed_within_m_of_home
                found += f", landed {self.landed[1]:.2f} m from home at {_clock(self.landed[0])}"
                decided = self.landed[0]
        return Verdict("failsafe", met, found, bound, decided.t_us, decided.clock)

    def no_failsafe_verdict(self, end: Moment) -> Verdict:
        if self.critical is None:
            return Verdict("no_failsafe", True, "never in a failsafe action", "no failsafe", end.t_us, end.clock)
        at, mode = self.critical
        return Verdict("no_failsafe", False, f"in a failsafe action (MAV_STATE_CRITICAL, {mode}) from {_clock(at)}",
                       "no failsafe", at.t_us, at.clock)

    def _flew(self, reaction: tuple[str, Moment]) -> str:
        assert self.trigger is not None
        held = [at for mode, at in self.modes_after if mode == HOLD and at.t_us < reaction[1].t_us]
        hold = f" (AUTO.LOITER {_after_s(self.trigger, held[0]):.2f} s after it)" if held and reaction[0] != HOLD \
            else ""
        return f"{reaction[0]} {_after_s(self.trigger, reaction[1]):.2f} s later{hold}"

    def _no_trigger(self) -> str:
        if self.after == "battery low":
            lowest = "none sent" if self.lowest_percent is None else f"the lowest sent {self.lowest_percent} %"
            return f"the battery never went below BAT_CRIT_THR {self.battery_threshold:g} ({lowest})"
        return f"{self.after} never happened: the flight did not reach its window"


def _clock(at: Moment) -> str:
    return f"mission time {at.clock:.2f} s" if at.clock is not None else f"bench time {at.t_us * 1e-6:.2f} s"


def _after_s(start: Moment, later: Moment) -> float:
    return (later.t_us - start.t_us) * 1e-6


def failsafe_judge(scenario: Scenario, expected: FailsafeExpected | None) -> FailsafeJudge:
    """The judge of the scenario's failsafe: its trigger's windows, the battery threshold PX4 acts at."""
    after = expected.after if expected is not None else None
    windows: list[tuple[float, float]] = []
    if after == "manual control lost":
        windows = joystick_losses(scenario)
    elif after == "data link lost":
        windows = [(w.start_s, w.end_s) for w in scenario.faults.ground_station]
    elif after == "gps lost":
        windows = gps_dropouts(scenario)
    return FailsafeJudge(after, windows, parameter(scenario, "BAT_CRIT_THR"))
