"""Wall-clock pacing of a step: sleep until its deadline, count a late start, slip after a stall."""

from __future__ import annotations

import time

from hil.loop.timing import LoopTiming

REALTIME_SLIP_S = 0.02  # paced run this far behind the wall clock (the machine stalled): go on from now


class Pacer:
    def __init__(self, period_s: float, timing: LoopTiming) -> None:
        self.period_s = period_s
        self.timing = timing

    def sleep_until(self, deadline: float, t_us: int) -> float:
        """Wait for the step's wall-clock deadline; returns the deadline kept. After a stall longer than
        REALTIME_SLIP_S the schedule slips instead of catching up: a burst of steps would hand the board a burst
        of sensor frames and let the plant run many steps on one stale actuator reply, while a slip is a pause
        both sides see as one late frame. Lateness is taken when the step starts, so a sleep that overslept
        counts as much as a step before it that ran long."""
        remaining = deadline - time.perf_counter()
        if remaining > 0.0005:
            time.sleep(remaining - 0.0003)
        while time.perf_counter() < deadline:
            pass
        started = time.perf_counter()
        behind = started - deadline
        if behind > self.period_s:
            self.timing.add_late(t_us, behind, started)
        if behind > REALTIME_SLIP_S:
            self.timing.add_slip(behind)
            deadline = started
        self.timing.add_step_start(started, self.period_s)
        return deadline
