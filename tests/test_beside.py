"""Work beside the run's start (hil/host/beside.py): waited for with its failure raised, and at a run's end waited for
as long as its thread computes, but not for ever on a lock nobody will release (a stop signal that landed inside a
lock taken by Python code leaves it so: the test reproduces that state with the lock taken by the waiting thread)."""

from __future__ import annotations

import subprocess
import sys
import threading
import time

import pytest

from hil.host.beside import Beside, beside


def test_the_wait_raises_what_the_work_raised_each_time():
    def fail() -> None:
        raise ValueError("no cache")

    waiting = beside(fail, "failing")
    for _ in range(2):
        with pytest.raises(ValueError, match="no cache"):
            waiting()
    assert waiting.settle() is True


def test_settle_waits_for_work_that_computes_longer_than_the_blocked_bound():
    def compute(seconds: float = 0.8) -> None:  # CPU all along: a compile, not a blocked thread
        until = time.thread_time() + seconds
        while time.thread_time() < until:
            pass

    started = time.monotonic()
    assert Beside(compute, "computing").settle(blocked_s=0.4) is True
    assert time.monotonic() - started >= 0.75  # it waited for the end, twice the bound


def test_settle_leaves_work_that_waits_on_a_lock_left_taken():
    left_taken = threading.RLock()  # as numba's compiler lock, after a KeyboardInterrupt inside its __enter__
    left_taken.acquire()
    try:
        started = time.monotonic()
        waiting = Beside(lambda: left_taken.acquire() and None, "blocked")
        assert waiting.settle(blocked_s=0.3) is False
        assert 0.3 <= time.monotonic() - started < 2.0
    finally:
        left_taken.release()
    assert waiting.settle(blocked_s=0.3) is True  # released: it takes the lock and ends


def test_settle_on_work_already_ended_returns_at_once():
    done = Beside(lambda: None, "quick")
    done()
    started = time.monotonic()
    assert done.settle() is True
    assert time.monotonic() - started < 0.1


ENDED_LONG_AGO = """
import threading, time
from hil.host.beside import Beside
done = Beside(lambda: None, "quick")
done()
# threads alive together take fresh stacks; as they end glibc's stack cache (40 MiB) overflows and unmaps the oldest,
# the quick thread's with its descriptor
threads = [threading.Thread(target=time.sleep, args=(0.2,)) for _ in range(16)]
for thread in threads:
    thread.start()
for thread in threads:
    thread.join()
print(done.settle())
"""


def test_settle_on_work_whose_thread_ended_long_ago_reads_no_freed_memory():
    """Seen in a clean CI run: a run's end settled a thread that had ended, through its freed descriptor
    (`pthread_getcpuclockid` of its handle), and the test process died of SIGSEGV in libc. In a process of its own:
    with the old way this exits by SIGSEGV (-11)."""
    ran = subprocess.run([sys.executable, "-c", ENDED_LONG_AGO], capture_output=True, text=True, timeout=60)
    assert (ran.returncode, ran.stdout.strip()) == (0, "True"), ran.stderr
