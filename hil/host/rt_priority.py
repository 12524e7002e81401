"""Keeping a run's loop from stalling: real-time scheduling for paced runs, a frozen heap for all.

On a shared machine a busy neighbour can hold a paced run off the CPU for tens of milliseconds (57 ms
was seen in CI), which the board reads as a late sensor frame and the plant as a stale actuator reply.
SCHED_FIFO at a low priority lets the bench and the emulator preempt ordinary work. Both sleep most of
each step, and Linux caps real-time tasks at 95 % of the CPU (kernel.sched_rt_runtime_us), so the
machine stays usable. Lockstep runs keep normal scheduling: they are CPU-bound by design.
"""

from __future__ import annotations

import gc
import os
from collections.abc import Iterator
from contextlib import contextmanager, suppress

FIFO_PRIORITY = 10  # low among real-time priorities (1..99): kernel threads and audio stay above


@contextmanager
def realtime_priority(pids: list[int]) -> Iterator[str]:
    """SCHED_FIFO for this thread and `pids` while the block runs, normal scheduling again after; yields
    what happened, for the run's log (without CAP_SYS_NICE nothing changes and it says so)."""
    targets = [0, *pids]
    raised: list[int] = []
    try:
        for pid in targets:
            os.sched_setscheduler(pid, os.SCHED_FIFO, os.sched_param(FIFO_PRIORITY))
            raised.append(pid)
        note = f"real-time priority: SCHED_FIFO {FIFO_PRIORITY} for the bench" + (" and the emulator" if pids else "")
    except OSError as exc:
        note = (f"real-time priority not granted ({exc.strerror}; needs root or CAP_SYS_NICE): "
                "a busy machine can stall this paced run")
    try:
        yield note
    finally:
        for pid in raised:
            with suppress(OSError):  # the board's process has ended meanwhile
                os.sched_setscheduler(pid, os.SCHED_OTHER, os.sched_param(0))


def current_fifo_priority() -> int:
    """This thread's SCHED_FIFO priority, 0 when it is not real-time."""
    if os.sched_getscheduler(0) != os.SCHED_FIFO:
        return 0
    return os.sched_getparam(0).sched_priority


def run_just_below(priority: int) -> None:
    """Put this thread one SCHED_FIFO priority under `priority` (nothing for 0 or 1). A helper thread of a
    paced loop (the recording's writer) must stay ahead of ordinary work, or it can be kept off the CPU
    holding the interpreter the loop waits for; and behind the loop, since at equal FIFO priority a
    thread keeps its core until it blocks, and the loop's wake-up would wait for it."""
    if priority > 1:
        with suppress(OSError):
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority - 1))


def board_on_its_own_core(instance: int = 0) -> None:
    """In a PX4 process the bench starts (SITL or the HITL rehearsal), before exec: all its threads on one
    CPU, the last for instance 0, the one before for instance 1, and so on, so that runs side by side spread
    over the CPUs. PX4's SCHED_FIFO threads (priorities 40-99, above everything else) otherwise spread over
    both cores of a small machine at once and preempt whatever runs there: measured here, PX4 SITL driven by
    a minimal simulator ran at 13.6x real time spread and 21.6x on one core, the bench with PX4 at 7.5x and
    11.7x, and a rehearsal's pacing p99 fell from 70-90 us to 3-81 us. (A Pixhawk has a processor of its own.)
    Nothing changes on a single-CPU machine."""
    cpus = sorted(os.sched_getaffinity(0))
    if len(cpus) > 1:
        os.sched_setaffinity(0, {cpus[-1 - instance % len(cpus)]})


@contextmanager
def frozen_heap() -> Iterator[None]:
    """What start-up built is moved out of the collector's reach for the flight (`gc.freeze`): it lives
    to the end, and a full collection over it stalled a run 40 ms. The young generations' garbage is collected
    first (a run collects the rest beside its board's start: a full collection takes ~80 ms, which a board that
    has connected should not wait) and the heap is unfrozen after, so a process that flies again leaks nothing."""
    gc.collect(generation=1)
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()
