"""Telling a board that dropped its lockstep reply from one that is slow to send it, on real processes: only a process
whose every thread sleeps and that uses no CPU is past answering (`firmware_interface.board_dropped_reply`)."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from functools import partial

from firmware_interface.board_dropped_reply import DROPPED_AFTER_S, LOOK_SPAN_S, DroppedReplies
from hil.host.process_cpu import threads_at_rest

ASLEEP = "import threading, time\nthreading.Thread(target=time.sleep, args=(60,)).start()\ntime.sleep(60)"
SPINNING = "import threading, time\nthreading.Thread(target=time.sleep, args=(60,)).start()\nwhile True: pass"


@contextmanager
def child(code: str) -> Iterator[subprocess.Popen[bytes]]:
    process = subprocess.Popen([sys.executable, "-c", code])
    try:
        time.sleep(0.5)  # its interpreter started, its threads in place
        yield process
    finally:
        process.kill()
        process.wait()


def waited_until_dropped(pid: int, give_up_s: float = 1.0) -> float | None:
    """How long a reply from `pid` was awaited before it counted as dropped, looking as the bench does (every
    LOOK_SPAN_S at most); None when it never did within `give_up_s`."""
    replies = DroppedReplies(partial(threads_at_rest, pid))
    started = time.monotonic()
    while (waited := time.monotonic() - started) < give_up_s:
        if replies.dropped(waited, 4000):
            assert replies.dropped_us == [4000]
            return waited
        time.sleep(LOOK_SPAN_S / 5)
    return None


def test_a_process_whose_threads_all_sleep_has_dropped_the_reply_after_the_wait_and_one_idle_span():
    with child(ASLEEP) as process:
        cpu_ns, asleep = threads_at_rest(process.pid) or (0, False)
        assert asleep and cpu_ns > 0  # its start-up's CPU, counted over both threads
        waited = waited_until_dropped(process.pid)
    assert waited is not None and DROPPED_AFTER_S + LOOK_SPAN_S <= waited < DROPPED_AFTER_S + 3 * LOOK_SPAN_S


def test_a_process_with_a_running_thread_or_stopped_is_waited_for():
    with child(SPINNING) as process:
        rest = threads_at_rest(process.pid)
        assert rest is not None and not rest[1]  # one of its threads runs
        assert waited_until_dropped(process.pid) is None
    with child(ASLEEP) as process:
        process.send_signal(signal.SIGSTOP)  # as a debugger or the machine's load would hold it: it will answer
        time.sleep(0.05)
        assert waited_until_dropped(process.pid) is None


def test_a_process_gone_is_the_watchdogs():
    with child(ASLEEP) as process:
        pid = process.pid
    assert threads_at_rest(pid) is None and waited_until_dropped(pid, 0.3) is None
