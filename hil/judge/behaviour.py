"""The flight's behaviour, whoever flies it, judged on the true state and on what the board reported: the mission
items it reached and in which order, its distance from the planned legs, the modes it went through, how high it
flew, when it was disarmed and where it came to rest. A sink of the loop; `verdicts` judges a scenario's behaviour
expectations (`expect:` mission_completed, home_within_m, max_cross_track_m, disarmed_by_s, max_altitude_m,
modes_seen, and through `hil.judge.failsafe` failsafe and no_failsafe), each with the bench time at which it was
decided."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from firmware_interface.px4_modes import mode_name
from hil.judge.failsafe import FailsafeJudge, failsafe_judge
from hil.judge.mission_progress import MissionProgress
from hil.judge.planned_path import PlannedPath
from hil.judge.verdict import Moment, Verdict
from hil.loop.frame import StepFrame
from hil.loop.sink import Outcome
from hil.loop.streaming_stats import Extremes
from hil.scenario.pilot_spec import BenchPilotSpec
from hil.scenario.schema import Bounds, Scenario

BEHAVIOUR = ("mission_completed", "home_within_m", "max_cross_track_m", "disarmed_by_s", "max_altitude_m",
             "modes_seen", "failsafe", "no_failsafe")


@dataclass
class BehaviourJudge:
    """Fed every step's frame; `figures` and `verdicts` at the end."""

    path: PlannedPath | None  # the mission the flight is judged against, when it has one
    bounds: Bounds | None = None  # the expectations, so that a bound is decided at the step that breaks it
    progress: MissionProgress[Moment] | None = None  # through that mission
    failsafes: FailsafeJudge = field(default_factory=lambda: FailsafeJudge(None, [], 0.0))  # triggers, reactions
    modes: dict[str, Moment] = field(default_factory=dict)  # each mode as first seen
    cross_track: Extremes = field(default_factory=lambda: Extremes(1))
    along_track_at_switch: dict[int, float] = field(default_factory=dict)  # leg -> progress when it was left
    max_height: tuple[float, Moment] | None = None
    first_over: dict[str, Moment] = field(default_factory=dict)  # a bound first broken
    disarmed: Moment | None = None  # the outputs disarmed after take-off
    _armed_after_takeoff = False
    _current: int | None = None
    _last_along: float = 0.0
    _last_cross_track: Moment | None = None
    _last: StepFrame | None = None

    def on_step(self, frame: StepFrame) -> None:
        now = Moment(frame.t_us, frame.mission_t)
        self.failsafes.on_step(frame)
        for kind, payload in frame.board:
            if kind == "HEARTBEAT" and payload["custom_mode"]:  # 0: PX4 booting, no mode yet
                mode = mode_name(payload["custom_mode"])
                self.modes.setdefault(mode, now)
                if self.progress is not None:
                    self.progress.mode(mode, now)
            elif self.progress is not None and kind == "MISSION_ITEM_REACHED":
                self.progress.item_reached(payload["seq"], now)
            elif self.progress is not None and kind == "MISSION_CURRENT":
                self._leg_switch(payload["seq"])
                self.progress.current_item(payload["seq"], now)
        height = -float(frame.truth.pos_ned[2])
        if self.max_height is None or height > self.max_height[0]:
            self.max_height = (height, now)
            self._over("max_altitude_m", height, now)
        self._armed_state(frame, now)
        if frame.phase == "mission" and self.path is not None and self._current is not None:
            self._track(frame.truth.pos_ned, now)
        self._last = frame

    def on_event(self, t_us: int, text: str) -> None:
        """Events carry nothing the behaviour is judged on."""

    def close(self, outcome: Outcome) -> None:
        """Nothing to close: `verdicts` and `figures` give the results."""

    def _armed_state(self, frame: StepFrame, now: Moment) -> None:
        if math.isfinite(frame.mission_t) and frame.mission_t >= 0 and frame.armed:
            self._armed_after_takeoff, self.disarmed = True, None
        elif self._armed_after_takeoff and not frame.armed and self.disarmed is None:
            self.disarmed = now
            if self.progress is not None:
                self.progress.landed(now)

    def _leg_switch(self, seq: int) -> None:
        if seq != self._current and self._current is not None and self.path is not None \
                and self.path.leg_to(self._current) is not None:
            self.along_track_at_switch[self._current] = self._last_along
        self._current = seq

    def _track(self, pos_ned: np.ndarray, now: Moment) -> None:
        assert self.path is not None and self._current is not None
        leg = self.path.leg_to(self._current)
        if leg is None or (self.progress is not None and self._current in self.progress.reached):
            return  # no leg toward this item, or its leg is flown: what follows is not on it (a landing)
        cross, self._last_along = leg.cross_and_along(pos_ned)
        self.cross_track.add(np.array((cross,)))
        self._last_cross_track = now
        self._over("max_cross_track_m", cross, now)

    def _over(self, name: str, value: float, now: Moment) -> None:
        bound = getattr(self.bounds, name, None) if self.bounds is not None else None
        if bound is not None and value > bound and name not in self.first_over:
            self.first_over[name] = now

    # --- results --------------------------------------------------------------------
    def figures(self) -> dict[str, Any]:
        """What the flight did, for metrics.json."""
        figures: dict[str, Any] = {"modes_seen": list(self.modes),
                                   "max_height_m": self.max_height[0] if self.max_height else None,
                                   "failsafe": self.failsafes.figures()}
        if self.progress is not None:
            figures["mission_items_reached"] = sorted(self.progress.reached)
        if self.path is not None:
            stats = self.cross_track.stats(("cross_track",))
            figures["path"] = {"legs": len(self.path.legs), "cross_track_m": stats.get("cross_track"),
                               "along_track_at_leg_end": {str(k): v for k, v in self.along_track_at_switch.items()}}
        rest = self.rest_offset_m()
        if rest is not None:
            figures["rest_from_home_m"] = rest
        if self.disarmed is not None:
            figures["disarmed_at_mission_s"] = self.disarmed.clock
        return figures

    def rest_offset_m(self) -> float | None:
        """How far from home, horizontally, the vehicle is at the end of the run (the truth)."""
        if self._last is None:
            return None
        return float(math.hypot(self._last.truth.pos_ned[0], self._last.truth.pos_ned[1]))

    def verdicts(self, bounds: Bounds | None) -> list[Verdict]:
        """Each behaviour expectation of `bounds`, judged."""
        if bounds is None or self._last is None:
            return []
        end = Moment(self._last.t_us, self._last.mission_t)
        judged: dict[str, Callable[[Any, Moment], Verdict]] = {
            "mission_completed": self._mission_completed, "home_within_m": self._home_within,
            "max_cross_track_m": self._max_cross_track, "disarmed_by_s": self._disarmed_by,
            "max_altitude_m": self._max_altitude, "modes_seen": self._modes_seen,
            "failsafe": self.failsafes.failsafe_verdict,
            "no_failsafe": lambda wanted, end: self.failsafes.no_failsafe_verdict(end)}
        return [judged[name](getattr(bounds, name), end) for name in BEHAVIOUR if getattr(bounds, name) is not None]

    def _verdict(self, name: str, met: bool, found: str, bound: str, when: Moment) -> Verdict:
        return Verdict(name, met, found, bound, when.t_us, when.clock)

    def _mission_completed(self, wanted: bool, end: Moment) -> Verdict:
        progress = self.progress
        assert progress is not None  # the scenario's checks: mission_completed needs a planned mission
        if progress.complete:
            found = f"every item reached in order ({progress.count} of {progress.count})"
            when = max(progress.reached.values(), key=lambda moment: moment.t_us)
        else:
            missing = progress.missing()
            found = (f"items reached {sorted(progress.reached)}" + (f", never {missing}" if missing else "")
                     + (", the current item went back" if progress.went_back else ""))
            when = end
        return self._verdict("mission_completed", progress.complete == wanted, found, str(wanted).lower(), when)

    def _home_within(self, limit: float, end: Moment) -> Verdict:
        offset = self.rest_offset_m()
        rest = self.disarmed if self.disarmed is not None else end
        if self.disarmed is None:
            return self._verdict("home_within_m", False, "never came to rest: not disarmed after take-off",
                                 f"≤ {limit:g} m from home", end)
        assert offset is not None
        return self._verdict("home_within_m", offset <= limit, f"came to rest {offset:.2f} m from home",
                             f"≤ {limit:g} m", rest)

    def _max_cross_track(self, limit: float, end: Moment) -> Verdict:
        stats = self.cross_track.stats(("cross_track",)).get("cross_track")
        if not stats:
            return self._verdict("max_cross_track_m", False, "no leg was flown", f"≤ {limit:g} m", end)
        over = self.first_over.get("max_cross_track_m")
        found = f"max {stats['max']:.2f} m from the planned legs (rms {stats['rms']:.2f} m)"
        return self._verdict("max_cross_track_m", over is None, found, f"≤ {limit:g} m",
                             over or self._last_cross_track or end)

    def _disarmed_by(self, deadline: float, end: Moment) -> Verdict:
        at = self.disarmed
        if at is None or at.clock is None or at.clock > deadline:
            found = "not disarmed after take-off" if at is None else f"disarmed at mission time {at.clock:.2f} s"
            return self._verdict("disarmed_by_s", False, found, f"by mission time {deadline:g} s", end)
        return self._verdict("disarmed_by_s", True, f"disarmed at mission time {at.clock:.2f} s",
                             f"by {deadline:g} s", at)

    def _max_altitude(self, limit: float, end: Moment) -> Verdict:
        height = self.max_height[0] if self.max_height else 0.0
        over = self.first_over.get("max_altitude_m")
        return self._verdict("max_altitude_m", over is None, f"highest {height:.2f} m above home",
                             f"≤ {limit:g} m", over or end)

    def _modes_seen(self, wanted: list[str], end: Moment) -> Verdict:
        missing = [mode for mode in wanted if mode not in self.modes]
        seen = ", ".join(self.modes) or "none"
        if missing:
            return self._verdict("modes_seen", False, f"never {', '.join(missing)} (seen: {seen})",
                                 ", ".join(wanted), end)
        last = max((self.modes[mode] for mode in wanted), key=lambda moment: moment.t_us)
        return self._verdict("modes_seen", True, f"seen: {seen}", ", ".join(wanted), last)


def behaviour_judge(scenario: Scenario, bounds: Bounds | None) -> BehaviourJudge:
    """The judge of a scenario's flight, against its planned mission when it has one: the mission pilot's, or the
    one an outside pilot is expected to fly (none for the bench pilot's flights)."""
    pilot = scenario.pilot
    failsafes = failsafe_judge(scenario, bounds.failsafe if bounds is not None else None)
    if isinstance(pilot, BenchPilotSpec) or not pilot.planned:
        return BehaviourJudge(None, bounds, failsafes=failsafes)
    return BehaviourJudge(PlannedPath(pilot.items, scenario.home.frame), bounds, MissionProgress(pilot.items),
                          failsafes)
