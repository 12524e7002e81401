"""A paced run's real-time priority: granted to the bench and the board's process, and given back."""

import os
import subprocess
from functools import partial
from pathlib import Path

import pytest

from hil.host.rt_priority import FIFO_PRIORITY, board_on_its_own_core, frozen_heap, realtime_priority, run_just_below
from tests.support.emulator_process import may_raise_priority


@pytest.mark.skipif(not may_raise_priority(), reason="needs root or CAP_SYS_NICE")
def test_the_bench_and_the_emulator_run_fifo_during_the_flight_and_normal_after():
    child = subprocess.Popen(["sleep", "30"])
    try:
        with realtime_priority([child.pid]) as note:
            for pid in (0, child.pid):
                assert os.sched_getscheduler(pid) == os.SCHED_FIFO
                assert os.sched_getparam(pid).sched_priority == FIFO_PRIORITY
            assert "SCHED_FIFO" in note and "emulator" in note
        for pid in (0, child.pid):
            assert os.sched_getscheduler(pid) == os.SCHED_OTHER
    finally:
        child.kill()
        child.wait()


def test_a_board_process_gone_before_the_end_does_not_fail_the_run():
    child = subprocess.Popen(["true"])
    child.wait()  # reaped: its pid names no process
    with realtime_priority([child.pid]) as note:
        assert note  # either way the run's log says what happened
    assert os.sched_getscheduler(0) == os.SCHED_OTHER


def test_the_heap_is_frozen_for_the_flight_after_collecting_garbage_and_unfrozen_after():
    import gc
    import weakref

    class Node:
        pass

    cycle = Node()
    cycle.me = cycle  # garbage only a collection frees
    gone = weakref.ref(cycle)
    del cycle
    with frozen_heap():
        assert gone() is None  # collected before the freeze, not frozen for ever
        assert gc.get_freeze_count() > 1000  # start-up's objects are out of the collector's reach
    assert gc.get_freeze_count() == 0


@pytest.mark.skipif(len(os.sched_getaffinity(0)) < 2, reason="one CPU: the board shares it by necessity")
def test_a_px4_instance_runs_on_one_cpu_side_by_side_ones_on_others_and_the_bench_keeps_all():
    allowed = sorted(os.sched_getaffinity(0))
    children = [subprocess.Popen(["sleep", "30"], preexec_fn=partial(board_on_its_own_core, n))  # noqa: PLW1509
                for n in (0, 1)]  # as PX4 instances 0 and 1 are started
    try:
        for child, cpu in zip(children, (allowed[-1], allowed[-2]), strict=True):
            status = Path(f"/proc/{child.pid}/status").read_text()
            assert f"Cpus_allowed_list:\t{cpu}\n" in status  # the kernel's own view of the child
        assert sorted(os.sched_getaffinity(0)) == allowed
    finally:
        for child in children:
            child.kill()
            child.wait()


@pytest.mark.skipif(not may_raise_priority(), reason="needs root or CAP_SYS_NICE")
def test_a_helper_thread_runs_one_fifo_priority_below_the_loop():
    import threading

    seen: list[tuple[int, int]] = []

    def helper() -> None:
        run_just_below(FIFO_PRIORITY)
        seen.append((os.sched_getscheduler(0), os.sched_getparam(0).sched_priority))

    thread = threading.Thread(target=helper)
    thread.start()
    thread.join()
    assert seen == [(os.SCHED_FIFO, FIFO_PRIORITY - 1)]
    assert os.sched_getscheduler(0) == os.SCHED_OTHER  # the calling thread is left as it was
