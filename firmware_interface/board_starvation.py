"""A board process the bench runs on this machine, on its own clock, that the machine starves of CPU.

A board on its own clock (the emulator behind injected link faults, paced on the wall clock) runs beside the plant:
the bench takes whatever reply has come and steps on. A board of its own never lacks a CPU; a process on this
machine can, when more work than cores is runnable (three test files at once: the emulator's replies stopped for
~0.1 s in flight, 3.2° of pitch error, while the bench itself ran on time). The plant flying on over such a gap
would charge the machine's stall to the flight. So the bench looks at the board's process each step, once the
step's frames are written: runnable (state R) and starved in one of two ways, it will answer late, and the bench
waits, reading the link, until it has answered and sleeps (so each step while the starving lasts); the paced
schedule then slips as after a stall of the bench's own, and the run says how often and how long. The two ways, from
/proc/PID/schedstat:
- no run at all for STARVED_S: its count of runs on a CPU unchanged (it grows as a run begins) and its CPU time
  too (a running task's grows at each scheduler tick). Its time queued for a CPU says nothing here: the kernel
  adds a wait to it only as the wait ends.
- thin slices: a real-time task above it on its core leaves it a fraction of a millisecond every few. It runs
  between any two looks, yet spends much of the time queued, each wait ending within a step or two: its time
  queued grew by more than QUEUED_SHARE of the last QUEUED_SPAN_S (the time of a wait is only known once it has
  ended, so a span of several steps). Starved so for 1 s (0.1 ms left every 4 ms), `link_faults.yaml`'s hover
  reached 49° of pitch error with the first way alone.
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

# Runnable this long without a run is starved: past a scheduler tick at 250 Hz (4 ms: a computation that long shows
# its CPU time by then), far past the board's usual wait for a CPU (tens of µs), far short of a gap that moves the
# vehicle (0.1 s: 3° of pitch in a hover).
STARVED_S = 0.005
# The share of the last QUEUED_SPAN_S spent queued for a CPU that starves it: a board that keeps up is queued ~1 % of
# it, and one late wake-up of a few ms is not enough
QUEUED_SHARE = 0.25
QUEUED_SPAN_S = 0.02
RECHECK_S = 0.001  # how often a starved board is looked at again (its link read meanwhile)
LONGEST_WAIT_S = 10.0  # a board process runnable longer than this is the watchdog's (`board_watchdog`), not a stall's


@dataclass(frozen=True)
class Look:
    """The process's schedstat at one look: when, its CPU time, its time queued for a CPU, its count of runs."""

    t_s: float
    cpu_ns: int
    queued_ns: int
    runs: int


class CpuStarvation:
    """Waits out the board process's waits for a CPU; `waits` and `waited_s` say how often and how long."""

    def __init__(self, schedule: Callable[[], tuple[int, int, int] | None], state: Callable[[], str | None],
                 clock: Callable[[], float] = time.monotonic) -> None:
        self._schedule = schedule  # the process's CPU ns, ns queued for a CPU and runs on a CPU so far (None: gone)
        self._state = state  # its scheduler state ("R": running or runnable)
        self._clock = clock
        self._looks: deque[Look] = deque()  # the looks of the last QUEUED_SPAN_S or more, oldest first
        self._unrun_since: Look | None = None  # the first of the looks in a row that found it runnable, not run since
        self.waits = 0
        self.waited_s = 0.0

    def _starved(self) -> bool:
        """Whether the process, looked at once a step's frames are written, waits for a CPU (the module's two ways)."""
        state, sample = self._state(), self._schedule()
        if state is None or sample is None:  # gone: the watchdog's business
            self._looks.clear()
            self._unrun_since = None
            return False
        look = Look(self._clock(), *sample)
        looks = self._looks
        looks.append(look)
        while len(looks) > 2 and look.t_s - looks[1].t_s >= QUEUED_SPAN_S:
            looks.popleft()
        if state != "R":  # asleep: it has answered what it was sent (the link's latency holds this step's frames)
            self._unrun_since = None
            return False
        unrun = self._unrun_since
        if unrun is None or (look.cpu_ns, look.runs) != (unrun.cpu_ns, unrun.runs):
            unrun = self._unrun_since = look
        span_s = look.t_s - looks[0].t_s
        queued = span_s >= STARVED_S and look.queued_ns - looks[0].queued_ns > QUEUED_SHARE * span_s * 1e9
        return queued or look.t_s - unrun.t_s >= STARVED_S

    def wait_out(self, poll: Callable[[float], object]) -> None:
        """Once a step's frames are written: while the process is starved, `poll(RECHECK_S)` the link until it
        sleeps; nothing when it is not."""
        if not self._starved():
            return
        started = self._clock()
        while self._clock() - started < LONGEST_WAIT_S and self._state() == "R":
            poll(RECHECK_S)
        self.waits += 1
        self.waited_s += self._clock() - started

    def figures(self) -> dict[str, float] | None:
        """metrics.json's `board_cpu_waits`: None when the bench never waited."""
        return {"count": self.waits, "total_s": self.waited_s} if self.waits else None
