"""CPU time a process has used, all its threads, from Linux's /proc: the board's own share of a lockstep
step (PX4's or the emulator's), beside the bench's breakdown of its own share."""

from __future__ import annotations

import os
from pathlib import Path

_TICK_S = 1.0 / os.sysconf("SC_CLK_TCK")
_UTIME, _STIME = 11, 12  # fields 14 and 15 of /proc/PID/stat, counted after the ")" that ends the name


def cpu_seconds(pid: int) -> float | None:
    """User + system CPU seconds of `pid` (a 10 ms tick on most kernels); None where /proc has no such
    process or there is no /proc."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    fields = text[text.rindex(")") + 2 :].split()
    return (int(fields[_UTIME]) + int(fields[_STIME])) * _TICK_S
