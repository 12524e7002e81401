"""The emulator board kind with something done to its process once it has started (stopped, starved), and whether
this machine lets a test give a process real-time priority."""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from hil.boards.emulator import EmulatorProcess, EmulatorTarget
from hil.boards.handle import BoardHandle
from hil.boards.target import BoardPolicy, LinkSettings
from hil.scenario.schema import Scenario


@dataclass(frozen=True)
class EmulatorWithItsProcess:
    """The emulator, with `started(pid)` called right after its first heartbeat, before the run's first step."""

    started: Callable[[int], None]
    label = "emulator"

    def policy(self, scenario: Scenario) -> BoardPolicy:
        return EmulatorTarget().policy(scenario)

    def attach(self, scenario: Scenario, run_dir: Path, settings: LinkSettings) -> BoardHandle:
        handle = EmulatorTarget().attach(scenario, run_dir, settings)
        assert isinstance(handle.process, EmulatorProcess)
        self.started(handle.process.popen.pid)
        return handle


def may_raise_priority() -> bool:
    """SCHED_FIFO is allowed here (root or CAP_SYS_NICE)."""
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(1))
    except OSError:
        return False
    os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    return True
