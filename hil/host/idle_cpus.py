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

Only a cpuidle driver heeds the request: a kernel with none (`current_driver` says "none", as on a Firecracker VM
whose host gives no halt-polling hint) always halts an idle CPU, whatever is asked. There the run says so instead of
claiming polling (cyclictest's average wake-up on such a host: 86 µs, docs/performance.md).
"""

from __future__ import annotations

import os
import struct
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

CPU_DMA_LATENCY = Path("/dev/cpu_dma_latency")
CPUIDLE_DRIVER = Path("/sys/devices/system/cpu/cpuidle/current_driver")
NO_WAKE_LATENCY_US = 0


def cpuidle_driver(path: Path = CPUIDLE_DRIVER) -> str:
    """The kernel's cpuidle driver ("none" where it has none, or no cpuidle at all)."""
    try:
        return path.read_text().strip() or "none"
    except OSError:
        return "none"


@contextmanager
def idle_cpus_polling(not_for: str | None = None, device: Path = CPU_DMA_LATENCY,
                      driver: Path = CPUIDLE_DRIVER) -> Iterator[str]:
    """Hold the request while the block runs, unless `not_for` says why not or no cpuidle driver would heed it;
    yields what holds, for the run's timing figures."""
    if not_for is not None:
        yield f"sleeping ({not_for})"
        return
    if cpuidle_driver(driver) == "none":
        yield f"sleeping: the kernel has no cpuidle driver ({driver}: none), so idle CPUs halt whatever is asked"
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
