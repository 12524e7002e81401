"""Start and stop one PX4 instance for one run, leaving nothing behind.

PX4 posix runs as a daemon (`bin/px4`) plus short-lived clients (`bin/px4-<module>`) that its
startup script calls; all of them are put in one process group of their own, so a terminal's
Ctrl-C reaches the bench only, and stopping the group stops every piece. Instances are
numbered: PX4 derives its daemon socket (/tmp/px4-sock-N), its system id (N + 1) and its
ports from N, so two runs side by side need two numbers.
"""

from __future__ import annotations

import fcntl
import os
import signal
import socket
import subprocess
import tempfile
import time
from collections.abc import Callable
from contextlib import suppress
from dataclasses import dataclass
from pathlib import Path
from typing import TypeVar

from firmware_interface.board import BoardError
from hil.boards.px4.build import Px4Build
from hil.host.lifetime import die_with_parent
from hil.host.rt_priority import board_on_its_own_core

MAX_INSTANCES = 16
SHUTDOWN_WAIT_S = 0.5  # `px4-shutdown` ends PX4 in ~10 ms; then SIGTERM, then SIGKILL
TERM_WAIT_S = 0.3
T = TypeVar("T")


class Px4StartError(RuntimeError):
    """PX4 could not be started or claimed (a board failure: exit 3)."""


def _daemon_running(instance: int) -> bool:
    """A PX4 daemon answers on /tmp/px4-sock-N (a stale socket file refuses the connection)."""
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as sock:
        try:
            sock.connect(f"/tmp/px4-sock-{instance}")
        except OSError:
            return False
    return True


@dataclass
class InstanceClaim:
    """An instance number this process holds (an flock, released with the process at the latest)."""

    number: int
    _fd: int

    def release(self) -> None:
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1


def claim_instance(reserve: Callable[[int], T | None]) -> tuple[InstanceClaim, T]:
    """The lowest instance that no other bench holds, no PX4 runs on, and for which `reserve(n)` (e.g.
    binding the simulator port 4560 + n) succeeds; returns the claim and what `reserve` returned."""
    for number in range(MAX_INSTANCES):
        fd = os.open(Path(tempfile.gettempdir()) / f"hil-px4-instance-{number}.lock", os.O_RDWR | os.O_CREAT, 0o666)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            continue
        reserved = None if _daemon_running(number) else reserve(number)
        if reserved is None:
            os.close(fd)
            continue
        return InstanceClaim(number, fd), reserved
    raise Px4StartError(f"no free PX4 instance among 0..{MAX_INSTANCES - 1} (other benches or PX4s hold them all)")


class Px4Process:
    """One PX4 daemon started by the bench; its console goes to `log_path`."""

    paced_with_bench = False  # PX4 gives its own tasks their scheduling

    def __init__(self, build: Px4Build, claim: InstanceClaim, rootfs: Path, log_path: Path,
                 env: dict[str, str], extra_args: tuple[str, ...] = (),
                 preexec: Callable[[], None] | None = None) -> None:
        self.build = build
        self.claim = claim
        self.log_path = log_path
        rootfs = rootfs.resolve()  # PX4 runs in it and is told it again: a relative path would nest in itself
        rootfs.mkdir(parents=True, exist_ok=True)
        argv = [str(build.px4), "-d", str(build.etc), "-w", str(rootfs), *extra_args, "-i", str(claim.number)]
        self._log = open(log_path, "wb")  # noqa: SIM115 - closed in stop()
        try:
            self.popen = subprocess.Popen(argv, cwd=rootfs, env={**os.environ, **env}, stdin=subprocess.DEVNULL,
                                          stdout=self._log, stderr=subprocess.STDOUT, start_new_session=True,
                                          preexec_fn=preexec)  # noqa: PLW1509 - PR_SET_PDEATHSIG: dies with parent
        except OSError as exc:
            self._log.close()
            raise Px4StartError(f"cannot start {build.px4}: {exc.strerror}") from exc

    @property
    def instance(self) -> int:
        return self.claim.number

    def exit_code(self) -> int | None:
        return self.popen.poll()

    def exit_note(self) -> str | None:
        code = self.popen.poll()
        if code is None:
            return None
        how = f"was killed by signal {-code}" if code < 0 else f"exited with code {code}"
        return f"PX4 {how}: {self.log_tail() or 'no output'} (console: {self.log_path})"

    def check_starting(self) -> None:
        """Raise BoardError when PX4 has exited before its first heartbeat (while the bench waits for it)."""
        code = self.exit_code()
        if code is not None:
            raise BoardError(f"PX4 exited during start-up (code {code}): {self.log_tail() or 'no output'} "
                             f"(console: {self.log_path})")

    def console_note(self) -> str | None:
        """PX4's last console lines, for a board failure while it runs: its simulator thread's "poll timeout" (a
        lockstep reply it dropped), a start-up script that stopped short of the bench's MAVLink instance."""
        return f"PX4's console ends: {self.log_tail() or 'nothing'} (console: {self.log_path})"

    def log_tail(self, lines: int = 3) -> str:
        try:
            text = self.log_path.read_text(errors="replace")
        except OSError:
            return ""
        useful = [line.strip() for line in text.splitlines() if line.strip() and "PX4 server not running" not in line]
        return " | ".join(useful[-lines:])

    def stop(self) -> None:
        """`px4-shutdown`, then SIGTERM, then SIGKILL to the whole group; returns within ~1.3 s."""
        if self.popen.poll() is None:
            with suppress(OSError, subprocess.TimeoutExpired):
                subprocess.run([str(self.build.client("shutdown")), "--instance", str(self.instance)],
                               stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                               timeout=SHUTDOWN_WAIT_S, start_new_session=True)
            self._wait(SHUTDOWN_WAIT_S)
        if self.popen.poll() is None:
            self._signal_group(signal.SIGTERM)
            self._wait(TERM_WAIT_S)
        self._signal_group(signal.SIGKILL)  # also the startup script's clients, if any outlived the daemon
        self.popen.wait()
        self._log.close()
        self.claim.release()

    def _wait(self, timeout_s: float) -> None:
        deadline = time.monotonic() + timeout_s
        while self.popen.poll() is None and time.monotonic() < deadline:
            time.sleep(0.01)

    def _signal_group(self, signum: int) -> None:
        with suppress(ProcessLookupError, PermissionError):
            os.killpg(self.popen.pid, signum)


def child_setup(instance: int) -> None:
    """In PX4's process before it runs: it dies with the bench, and runs on a CPU of its own per instance."""
    die_with_parent()
    board_on_its_own_core(instance)
