"""Work started on a thread of its own, beside what the caller does meanwhile (a board's start: a process start-up's
worth of waiting), the call that waits for it, and the wait a run's end gives it."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

# How long a thread beside may sit without using CPU, unfinished, before a run's end stops waiting for it: loading
# the compiled step never blocks that long (it computes, or reads the disk cache), a thread waiting on a lock that
# nobody will release blocks for ever.
BLOCKED_S = 3.0
_LOOK_S = 0.1


class Beside:
    """`work` started on a daemon thread. Calling this waits for it and raises what it raised (as often as it is
    called); `settle` is the wait of a run that is ending."""

    def __init__(self, work: Callable[[], None], name: str) -> None:
        self._work = work
        self._failure: list[BaseException] = []
        # the thread's CPU clock, named by its kernel thread id (taken by the thread itself): `pthread_getcpuclockid`
        # of a thread that has ended reads its freed descriptor, which killed a test process (SIGSEGV in libc, a
        # clean CI run); a clock named by the id of an ended thread only fails to read
        self._cpu_clock = -1
        self._clock_named = threading.Event()
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()
        self._clock_named.wait()

    def _run(self) -> None:
        self._cpu_clock = time.pthread_getcpuclockid(threading.get_ident())
        self._clock_named.set()
        try:
            self._work()
        except BaseException as exc:  # raised where the caller waits for it
            self._failure.append(exc)

    def __call__(self) -> None:
        self._thread.join()
        if self._failure:
            raise self._failure[0]

    def settle(self, blocked_s: float = BLOCKED_S) -> bool:
        """Wait for the work to end, unless its thread has used no CPU for `blocked_s`; whether it ended. A stop
        signal raises KeyboardInterrupt wherever the main thread is, and in a lock taken by Python code (numba's
        compiler lock, an import's module lock) it can land after the lock is taken and before its `with` holds
        it: the lock then stays taken, and a thread beside that waits for it waits for ever (a SIGTERM 0.8 s
        into a run's start left `hil run` waiting here until the test's 60 s ran out, once in a clean CI run).
        Exiting while the thread computes inside numba's compiler killed the process (SIGSEGV, SIGABRT): hence
        waiting for as long as it computes."""
        thread, cpu_clock = self._thread, self._cpu_clock
        try:
            cpu_s, still_since = time.clock_gettime(cpu_clock), time.monotonic()
            while True:
                thread.join(_LOOK_S)
                if not thread.is_alive():
                    return True
                now_cpu_s = time.clock_gettime(cpu_clock)
                if now_cpu_s != cpu_s:
                    cpu_s, still_since = now_cpu_s, time.monotonic()
                elif time.monotonic() - still_since >= blocked_s:
                    return False
        except OSError:  # the thread ended between two looks: its CPU clock went with it
            thread.join()
        return True


def beside(work: Callable[[], None], name: str) -> Beside:
    """Start `work` now on a daemon thread; returns what waits for it."""
    return Beside(work, name)
