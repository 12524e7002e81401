"""Idle CPUs kept polling while a run flies, for the wake-ups of a lockstep loop.

Each lockstep step wakes a sleeping process twice (the board for its sensor frames, the bench for the reply), and
a pty's data is moved by a kernel worker that is woken too. On an idle CPU each wake-up waits for the CPU to leave
its idle state: ~40 µs a time on this project's 2-core VM (its halt is an exit to the host), about a third of a
step. A PM QoS request of 0 µs on /dev/cpu_dma_latency makes the kernel's cpuidle governor keep idle CPUs polling
instead (cyclictest makes the same request unless told `--laptop`). Polling runs only where nothing else is
runnable, so it takes no CPU from other work; it costs power, which is what `hil run --power-save` is for. The
kernel drops the request when its file is closed, however the process ends.

Only lockstep runs hold it. To the host a polling vCPU is a busy one (its steal time rose with it here), and a
paced run with it saw one step 100 ms late where cyclictest beside it saw no stall: a paced run's worst wake-up
counts more than its typical one, and a lockstep run loses only wall time to a stall.
"""

from __future__ import annotations

import os
import struct
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

CPU_DMA_LATENCY = Path("/dev/cpu_dma_latency")
NO_WAKE_LATENCY_US = 0


@contextmanager
def idle_cpus_polling(not_for: str | None = None, device: Path = CPU_DMA_LATENCY) -> Iterator[str]:
    """Hold the request while the block runs, unless `not_for` says why not; yields what holds, for the run's timing
    figures."""
    if not_for is not None:
        yield f"sleeping ({not_for})"
        return
    try:
        fd = os.open(device, os.O_WRONLY)
    except OSError as exc:
        yield f"sleeping: {device} not writable ({exc.strerror}; needs root)"
        return
    try:
        os.write(fd, struct.pack("=i", NO_WAKE_LATENCY_US))
        note = f"polling ({device} held at {NO_WAKE_LATENCY_US} us)"
    except OSError as exc:
        note = f"sleeping: {device} refused the request ({exc.strerror})"
    try:
        yield note
    finally:
        os.close(fd)
