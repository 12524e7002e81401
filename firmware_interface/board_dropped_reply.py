"""A lockstep reply the board dropped: PX4 SITL, now and then, leaves a HIL_SENSOR unanswered.

In lockstep each end waits for the other: PX4 for the next HIL_SENSOR (its simulator thread polls 1 s at a time,
"poll timeout 0, 22" in its console), the bench for the HIL_ACTUATOR_CONTROLS that answers the last one. PX4 v1.15.4
on this 2-core machine, three flights at once beside its real-time threads, missed a reply in ~1 run of 100: its
console shows the poll timeouts, the tlog the last HIL_SENSOR unanswered, and the watchdog ended the flight. PX4's
own tracker knows the failure ("Sometimes PX4 simply stops sending HIL actuator controls", PX4-Autopilot #13442;
the CI poll timeouts of #13371). Gazebo's plugin waits for ever there; the bench, which can see PX4's process,
tells a dropped reply from a slow one: every thread of PX4's asleep (none runnable, stopped or in the kernel) and
next to no CPU used over LOOK_SPAN_S, with the reply DROPPED_AFTER_S late, PX4 waits for input and will not answer
that step. The bench then steps on with PX4's last outputs (the next HIL_SENSOR, which PX4 answers), and the run says
which steps it stepped past. A board silent for its whole watchdog is still a hung board.
"""

from __future__ import annotations

import time
from collections.abc import Callable

# A lockstep reply this late is looked into: far past PX4's replies on a loaded machine (p99 2.4 ms with three
# flights at once on 2 cores), a fifth of the default watchdog.
DROPPED_AFTER_S = 0.2
LOOK_SPAN_S = 0.1  # the board idle over this span of wall time, from one look to the next
# The share of a CPU the board's process may use over LOOK_SPAN_S and still count as idle: PX4 waiting for its next
# HIL_SENSOR used 0.5 % (its MAVLink instances poll their sockets on the wall clock); computing, it uses a whole CPU
IDLE_CPU_SHARE = 0.02


class DroppedReplies:
    """Tells, while a lockstep reply is awaited, when the board has dropped it; `dropped_us` the steps stepped past."""

    def __init__(self, look: Callable[[], tuple[int, bool] | None],
                 clock: Callable[[], float] = time.monotonic) -> None:
        self._look = look  # the process's CPU ns so far (all its threads) and whether every thread is asleep
        self._clock = clock
        self._idle_since: tuple[float, int] | None = None  # the first look of the idle looks in a row: when, CPU ns
        self.dropped_us: list[int] = []

    def dropped(self, waited_s: float, t_us: int) -> bool:
        """True once the reply to the step at `t_us`, awaited for `waited_s`, is dropped (recorded in `dropped_us`)."""
        if waited_s < DROPPED_AFTER_S:
            self._idle_since = None
            return False
        look, now = self._look(), self._clock()
        if look is None or not look[1]:  # gone (the watchdog's), or a thread that runs, waits or is stopped
            self._idle_since = None
            return False
        if self._idle_since is None:
            self._idle_since = (now, look[0])
            return False
        since_s, since_cpu_ns = self._idle_since
        if now - since_s < LOOK_SPAN_S:
            return False
        if look[0] - since_cpu_ns > IDLE_CPU_SHARE * (now - since_s) * 1e9:  # it computed meanwhile: look on
            self._idle_since = (now, look[0])
            return False
        self._idle_since = None
        self.dropped_us.append(t_us)
        return True

    def figures(self) -> dict[str, object] | None:
        """metrics.json's `timing.lockstep_replies_dropped`: None when none was."""
        if not self.dropped_us:
            return None
        return {"count": len(self.dropped_us), "at_s": [t_us / 1e6 for t_us in self.dropped_us]}
