"""How long a board may be silent before the bench gives up on it: the link watchdog, and the longer allowance of a
lockstep board while it boots.

A booting board's silence is not a hang. PX4 SITL starts its modules (processes of their own) in wall-clock time
beside the first steps, and on a starved machine its silence before its first replies passed 1 s ("silent 1.01 s at
0.04 s simulated"), as did the bench's own set-up between PX4's heartbeat and the first step (1.4-2.5 s measured
with two flights at once on 2 cores). The limit then is the time the board
had to send its first heartbeat (its start timeout, `--connect-timeout`): a board that never answers still ends the
run. A board on its own clock (a Pixhawk, PX4's HITL path) streams from its boot on and gets no allowance.

Nor is a lockstep board's silence a hang while its process is runnable: on a machine with more work than cores
(three test files at once beside PX4's real-time threads: "board silent for 1.01 s" mid-flight, the emulator's
replies 0.46 s late just before) the board waits for a CPU, and in lockstep the machine's delay is no fault of the
flight. Where the bench runs the board's process itself it tells the watchdog that process's scheduler state:
runnable, it is waited for up to RUNNABLE_MAX_S; otherwise (asleep, stopped, gone) the limit stands, and the
message says which.
"""

from __future__ import annotations

from collections.abc import Callable

from firmware_interface.board_dropped_reply import DroppedReplies
from firmware_interface.board_requests import BoardError

# A lockstep board's boot lasts until its replies reach this much simulated time past its first reply. PX4 SITL's
# start-up script goes on starting modules after that reply (its MAVLink instances, then the logger, the last:
# measured at 0.45-0.98 s simulated, two flights at once on 2 cores included); twice the latest. On simulated time,
# so that a stall's verdict depends on where in the flight it falls, not on how fast the machine got there.
BOOT_US = 2_000_000
# How long a board process past its limit may stay runnable (waiting for a CPU, or computing) before it counts as
# hung: ten times the default watchdog, well past the machine's stalls measured beside flights here (cyclictest's
# worst wake-ups 4-13 ms; the busiest CI moment's silence 1.01 s).
RUNNABLE_MAX_S = 10.0
RUNNABLE_RECHECK_S = 0.05  # how often a lockstep reply past the watchdog is looked for while the board waits for a CPU
# Linux's scheduler states (/proc/PID/stat), in the words a silence's message uses
PROCESS_STATES = {"R": "runnable", "S": "asleep", "D": "in an uninterruptible wait", "T": "stopped",
                  "t": "stopped by a tracer", "Z": "exited"}


class LinkWatchdog:
    """The silence limit of one link: `watchdog_s`, or while a lockstep board boots its start timeout if longer."""

    def __init__(self, watchdog_s: float, lockstep_board: bool) -> None:
        self.watchdog_s = watchdog_s
        self.start_timeout_s: float | None = None  # the time the board had to start speaking (the handshake's)
        self.booting = lockstep_board
        self._boot_ends_us: int | None = None  # BOOT_US past the first reply
        # the scheduler state of the board's process ("R", "S", ...; None: gone), where the bench runs it
        self.process_state: Callable[[], str | None] | None = None
        self.dropped_replies: DroppedReplies | None = None  # where the bench can tell a dropped lockstep reply

    def reply_dropped(self, waited_s: float, t_us: int) -> bool:
        """The lockstep reply to the step at `t_us`, awaited for `waited_s`, will not come (`board_dropped_reply`)."""
        return self.dropped_replies is not None and self.dropped_replies.dropped(waited_s, t_us)

    @property
    def limit_s(self) -> float:
        if self.booting and self.start_timeout_s is not None:
            return max(self.start_timeout_s, self.watchdog_s)
        return self.watchdog_s

    def replied(self, t_us: int) -> None:
        """A reply to the step at `t_us`: the boot ends with the one BOOT_US past the first."""
        if self.booting:
            if self._boot_ends_us is None:
                self._boot_ends_us = t_us + BOOT_US
            self.booting = t_us < self._boot_ends_us

    def check(self, silent_s: float, link_name: str) -> bool:
        """BoardError, saying which limit, when the board has been silent longer than it may; True while a board
        process past its limit is runnable (wait on: its silence is the machine's), False within the limit."""
        limit = self.limit_s
        if silent_s <= limit:
            return False
        state = self.process_state() if self.process_state is not None else None
        if state == "R" and silent_s <= RUNNABLE_MAX_S:
            return True
        process = "" if self.process_state is None else f"; its process {PROCESS_STATES.get(state or 'Z', state)}"
        if state == "R":
            process += f" past {RUNNABLE_MAX_S:g} s"
        if limit > self.watchdog_s:
            raise BoardError(f"board silent for {silent_s:.2f} s on {link_name} while it boots (allowed {limit:g} s, "
                             f"its start timeout, until its replies span {BOOT_US / 1e6:g} s of simulated time"
                             f"{process})")
        raise BoardError(f"board silent for {silent_s:.2f} s on {link_name} (watchdog {self.watchdog_s:.2f} s"
                         f"{process})")
