"""The loop's own timing: where a step's wall time goes (`lap`), the board's round trip, and, for a run paced on
the wall clock, the step-period jitter, late steps (each of the first few explained) and slips; metrics.json's
`timing`."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

from hil.loop.streaming_stats import LogHistogram

LATE_DETAIL = 20  # late steps explained in metrics.json (all are counted)
# wait_for_board: blocked in the link's read until the reply's bytes came (and that read); board_reply: the reply
# handled once there (its frames found, decoded, taken by the session). Apart, they tell whether a lockstep step
# waits for the board or the board's reply waits for the bench.
BREAKDOWN_PARTS = ("phase_and_environment", "plant", "sensors_and_send", "command_link_and_relay",
                   "previous_step_messages_and_sinks", "wait_for_board", "board_reply", "frame")


@dataclass
class LoopTiming:
    step_wall: LogHistogram = field(default_factory=LogHistogram)
    round_trip: LogHistogram = field(default_factory=LogHistogram)
    period_error: LogHistogram = field(default_factory=LogHistogram)  # |step period - nominal|, real time
    late_steps: int = 0
    late_detail: list[dict[str, Any]] = field(default_factory=list)  # the first LATE_DETAIL late steps, explained
    slips: int = 0  # stalls after which the real-time schedule went on from the late moment
    slipped_s: float = 0.0
    steps: int = 0
    breakdown_s: dict[str, float] = field(default_factory=lambda: dict.fromkeys(BREAKDOWN_PARTS, 0.0))
    sim_s: float = 0.0
    wall_s: float = 0.0
    board_cpu_s: float | None = None  # CPU the board's process used while the bench stepped (one it started)
    started: float = 0.0  # this step's start (perf_counter)
    longest: tuple[str, float] = ("", 0.0)  # this step's longest part and its seconds: why a step ran late
    _last: float = 0.0
    _last_step_start: float | None = None

    def start(self) -> float:
        self.started = self._last = time.perf_counter()
        self.longest = ("", 0.0)
        return self.started

    def lap(self, part: str, waited_part: str = "", waited_s: float = 0.0) -> float:
        """Charge the wall time since the previous lap (or `start`) to `part`, less `waited_s` of it charged to
        `waited_part` (the time the lap spent blocked in a read)."""
        now = time.perf_counter()
        if waited_part:
            self._charge(waited_part, waited_s)
        self._charge(part, now - self._last - waited_s)
        self._last = now
        return now

    def _charge(self, part: str, seconds: float) -> None:
        self.breakdown_s[part] += seconds
        if seconds > self.longest[1]:
            self.longest = (part, seconds)

    def add_step(self, step_wall_s: float, round_trip_s: float | None) -> None:
        self.steps += 1
        self.step_wall.add(step_wall_s)
        if round_trip_s is not None:
            self.round_trip.add(round_trip_s)

    def add_step_start(self, start_s: float, period_s: float) -> None:
        """Real-time pacing: the wall-clock start of a step, for the period jitter."""
        if self._last_step_start is not None:
            self.period_error.add(abs(start_s - self._last_step_start - period_s))
        self._last_step_start = start_s

    def add_late(self, t_us: int, behind_s: float, started_s: float) -> None:
        """A step that started more than a period late, with the longest part of the step before it (a slow
        part of the bench, or, when that part is short, a stall outside the step: the sleep or the machine), and
        when it started on the machine's monotonic clock (`perf_counter`: CLOCK_MONOTONIC, the clock of a
        latency measurement taken beside the run, such as cyclictest's)."""
        self.late_steps += 1
        if len(self.late_detail) < LATE_DETAIL:
            self.late_detail.append({"t_s": t_us * 1e-6, "behind_ms": behind_s * 1e3,
                                     "longest_part": self.longest[0], "longest_part_ms": self.longest[1] * 1e3,
                                     "monotonic_s": started_s})

    def add_slip(self, behind_s: float) -> None:
        self.slips += 1
        self.slipped_s += behind_s

    def figures(self, paced: bool) -> dict[str, Any]:
        wall = self.wall_s
        result: dict[str, Any] = {
            "sim_s": self.sim_s, "wall_s": wall, "realtime_factor": self.sim_s / wall if wall > 0 else None,
            "step_wall_us": self.step_wall.summary(1e6), "round_trip_us": self.round_trip.summary(1e6),
            "breakdown_us_per_step": {k: v / max(self.steps, 1) * 1e6 for k, v in self.breakdown_s.items()},
            "board_cpu_us_per_step": (self.board_cpu_s / self.steps * 1e6
                                      if self.board_cpu_s is not None and self.steps else None),
        }
        if paced and self.period_error.n:
            result["period_jitter_us"] = self.period_error.summary(1e6)
            result["late_steps"] = self.late_steps
            result["late_steps_detail"] = self.late_detail
            result["slips"] = {"count": self.slips, "total_s": self.slipped_s}
        return result
