"""What Linux's /proc says of a board process the bench runs: the CPU time it has used, all its threads (the board's
own share of a lockstep step, PX4's or the emulator's, beside the bench's breakdown of its own share), and its
scheduler state, and its CPU time, time queued for a CPU and runs on a CPU from schedstat (whether a board is waiting
for a CPU: `firmware_interface.board_watchdog`, `firmware_interface.board_starvation`), and whether all its threads
rest (a lockstep reply it dropped: `firmware_interface.board_dropped_reply`)."""

from __future__ import annotations

import os
from pathlib import Path

_TICK_S = 1.0 / os.sysconf("SC_CLK_TCK")
_STATE, _UTIME, _STIME = 0, 11, 12  # fields 3, 14 and 15 of /proc/PID/stat, counted after the ")" ending the name


def _stat_fields(pid: int) -> list[str] | None:
    """/proc/PID/stat's fields after the process's name (which may hold spaces); None where there is no such
    process or no /proc."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    return text[text.rindex(")") + 2 :].split()


def cpu_seconds(pid: int) -> float | None:
    """User + system CPU seconds of `pid` (a 10 ms tick on most kernels); None where /proc has no such
    process or there is no /proc."""
    fields = _stat_fields(pid)
    return None if fields is None else (int(fields[_UTIME]) + int(fields[_STIME])) * _TICK_S


def scheduler_state(pid: int) -> str | None:
    """`pid`'s main thread's state as the scheduler has it: R (running or waiting for a CPU), S (asleep), D, T
    (stopped), Z, ...; None where there is no such process or no /proc."""
    fields = _stat_fields(pid)
    return None if fields is None else fields[_STATE]


def cpu_schedule(pid: int) -> tuple[int, int, int] | None:
    """`pid`'s main thread's CPU nanoseconds, nanoseconds queued for a CPU and count of runs on a CPU
    (/proc/PID/schedstat's three fields; the CPU time is brought up to date at each scheduler tick and switch, the
    queued time as each wait ends); None where there is no such process, or the kernel keeps no schedstat."""
    try:
        cpu_ns, queued_ns, runs = (int(field) for field in Path(f"/proc/{pid}/schedstat").read_text().split()[:3])
    except (OSError, ValueError):
        return None
    return cpu_ns, queued_ns, runs


def threads_at_rest(pid: int) -> tuple[int, bool] | None:
    """The CPU nanoseconds all `pid`'s threads have used (schedstat's first field) and whether every one of them is
    asleep (S) or gone; None where there is no such process or the kernel keeps no schedstat
    (`firmware_interface.board_dropped_reply`)."""
    try:
        tids = os.listdir(f"/proc/{pid}/task")
    except OSError:
        return None
    cpu_ns, asleep = 0, True
    for tid in tids:
        try:
            stat = Path(f"/proc/{pid}/task/{tid}/stat").read_text()
            schedstat = Path(f"/proc/{pid}/task/{tid}/schedstat").read_text()
        except FileNotFoundError:
            continue  # the thread ended meanwhile
        except OSError:
            return None
        cpu_ns += int(schedstat.split()[0])
        asleep = asleep and stat[stat.rindex(")") + 2] in "SZX"
    return cpu_ns, asleep
