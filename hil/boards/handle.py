"""An attached board as the run sees it: its links, what flies on it, the process the bench started for it, and
the ground-station relay."""

from __future__ import annotations

import subprocess
from contextlib import suppress
from dataclasses import dataclass, field
from typing import Protocol

from firmware_interface.board import BoardSession
from hil.boards.gcs_relay import GcsBridge
from hil.host.process_cpu import cpu_seconds


class ChildProcess(Protocol):
    """What the bench uses of a process it started: `subprocess.Popen`'s, or a forked emulator's
    (`hil.boards.forked_emulator`)."""

    pid: int

    def poll(self) -> int | None: ...

    def wait(self, timeout: float | None = None) -> int: ...

    def terminate(self) -> None: ...

    def kill(self) -> None: ...


class Closable(Protocol):
    def close(self) -> None: ...


class BoardProcess(Protocol):
    """A board process the bench started (the emulator, PX4) and stops at the end of the run."""

    paced_with_bench: bool  # a paced run raises it to real-time priority with the bench (a PX4 schedules itself)

    @property
    def popen(self) -> ChildProcess: ...

    def stop(self) -> None: ...

    def exit_note(self) -> str | None: ...

    def console_note(self) -> str | None: ...


@dataclass
class BoardHandle:
    hil_session: BoardSession  # the HIL link: sensors out, actuators in
    command_session: BoardSession  # heartbeat, commands, setpoints: the HIL session unless the board has its own
    description: str
    process: BoardProcess | None = None
    params: dict[str, float | int] = field(default_factory=dict)  # set on the board before arming (an int: INT32)
    gcs: GcsBridge | None = None  # relays the board's traffic to ground stations and back

    @property
    def own_command_link(self) -> bool:
        """PX4 SITL's commands come on a UDP link its own thread serves, apart from the lockstep HIL link."""
        return self.command_session is not self.hil_session

    @property
    def sessions(self) -> list[BoardSession]:
        """Each link to the board once: the HIL link, and the command link when it is a separate one."""
        return [self.hil_session, self.command_session] if self.own_command_link else [self.hil_session]

    def relay_to(self, gcs: GcsBridge) -> None:
        self.gcs = gcs
        for session in self.sessions:
            session.relay_to_ground_stations()

    def realtime_pids(self) -> list[int]:
        """The board processes a paced run raises to real-time priority with the bench."""
        return [self.process.popen.pid] if self.process is not None and self.process.paced_with_bench else []

    def cpu_s(self) -> float | None:
        """CPU seconds the board's process has used, when the bench started it (None for a board attached)."""
        return cpu_seconds(self.process.popen.pid) if self.process is not None else None

    def exit_note(self, wait_s: float = 0.0) -> str | None:
        """Why the board's process ended, when the bench started it and it is gone (a board failure's cause). A
        process that is being killed closes its links before its exit is posted: a bench that read the reset at
        once found it still running (CI, once, for a SIGKILLed PX4); `wait_s` gives it that long to be gone."""
        if self.process is None:
            return None
        with suppress(subprocess.TimeoutExpired):
            self.process.popen.wait(wait_s)
        return self.process.exit_note()

    def console_note(self) -> str | None:
        """What the board's process last printed, where that says more than its log's place (PX4's console)."""
        return None if self.process is None else self.process.console_note()

    def close(self) -> None:
        """Stop what the bench started (PX4 included: nothing is left running), then close the links."""
        if self.process is not None:
            self.process.stop()
        for session in self.sessions:
            session.link.close()
        if self.gcs is not None:
            self.gcs.close()


def abandon_attach(handle: BoardHandle | None, process: BoardProcess, link: Closable) -> None:
    """An attach stopped once its board's process started (a failure, or a stop signal landing anywhere in it): the
    handle closed once there is one, else the process stopped and the link closed, so that nothing is left running."""
    if handle is not None:
        handle.close()
    else:
        process.stop()
        link.close()
