"""An emulator forked by a warm fork server (`firmware_interface.forkserver`), seen as the bench sees a process it
started: its pid, whether it has ended and with what code, and a way to stop it.

It is the server's child, not the bench's, so its end comes as the server's `exit` line; signals go through a pidfd,
which names that very process (a pid alone could have been reused once it was reaped). Also here: a server for a
block (`emulator_forkserver`) or for the rest of a process (`warm_emulators_for_this_process`)."""

from __future__ import annotations

import atexit
import contextlib
import os
import select
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator

from firmware_interface.forkserver import FORKSERVER_ENV, parse_lines, send_request

ANSWER_S = 5.0  # the server forks at once; a server that does not answer within this is treated as absent


class ForkedEmulator:
    """The subset of `subprocess.Popen` the bench uses, for an emulator the fork server started."""

    def __init__(self, conn: socket.socket, pid: int, answers: bytes) -> None:
        self._conn = conn
        self._answers = answers
        self.pid = pid
        self.returncode: int | None = None
        self._pidfd: int | None = None
        with contextlib.suppress(ProcessLookupError):  # already ended and reaped: its exit line is on its way
            self._pidfd = os.pidfd_open(pid)
        self._read_answers(0.0)

    def poll(self) -> int | None:
        if self.returncode is None:
            self._read_answers(0.0)
        return self.returncode

    def wait(self, timeout: float | None = None) -> int:
        deadline = None if timeout is None else time.monotonic() + timeout
        while self.returncode is None:
            left = None if deadline is None else deadline - time.monotonic()
            if left is not None and left <= 0:
                raise subprocess.TimeoutExpired(f"emulator {self.pid}", timeout or 0.0)
            self._read_answers(left)
        return self.returncode

    def terminate(self) -> None:
        self._signal(signal.SIGTERM)

    def kill(self) -> None:
        self._signal(signal.SIGKILL)

    def _signal(self, signum: int) -> None:
        if self._pidfd is not None and self.returncode is None:
            with contextlib.suppress(ProcessLookupError):
                signal.pidfd_send_signal(self._pidfd, signum)

    def _read_answers(self, timeout_s: float | None) -> None:
        """Whatever the server has said, waiting up to `timeout_s` for more. A server gone before the exit line
        (killed) leaves the code unknown: the process is then waited for through its pidfd, and counted as -9."""
        if "exit" not in parse_lines(self._answers) and select.select([self._conn], [], [], timeout_s)[0]:
            chunk = self._conn.recv(4096)
            self._answers += chunk
            if not chunk and "exit" not in parse_lines(self._answers):
                self._server_gone(timeout_s)
                return
        code = parse_lines(self._answers).get("exit")
        if code is not None:
            self._ended(code)

    def _server_gone(self, timeout_s: float | None) -> None:
        if self._pidfd is None or select.select([self._pidfd], [], [], timeout_s)[0]:
            self._ended(-signal.SIGKILL)

    def _ended(self, code: int) -> None:
        self.returncode = code
        self._conn.close()
        if self._pidfd is not None:
            os.close(self._pidfd)
            self._pidfd = None


def fork_emulator(server_path: str, args: list[str], log_fd: int) -> ForkedEmulator:
    """An emulator with `args` forked by the server at `server_path`, writing to `log_fd` (OSError: no server
    answers there)."""
    conn = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        conn.settimeout(ANSWER_S)
        conn.connect(server_path)
        send_request(conn, args, os.getcwd(), log_fd)
        answers = b""
        while "pid" not in parse_lines(answers):
            chunk = conn.recv(4096)
            if not chunk:
                raise ConnectionError(f"the emulator fork server at {server_path} closed without forking")
            answers += chunk
        conn.settimeout(None)
    except BaseException:
        conn.close()
        raise
    return ForkedEmulator(conn, parse_lines(answers)["pid"], answers)


@contextlib.contextmanager
def emulator_forkserver() -> Iterator[str]:
    """A warm fork server for the emulators started inside the block, by this process or any it starts (a `hil run`
    inherits `FORKSERVER_ENV`); stopped at the end. Yields its socket's path."""
    with tempfile.TemporaryDirectory(prefix="hil-forkserver-", ignore_cleanup_errors=True) as home:
        path = os.path.join(home, "emulators.sock")
        server = subprocess.Popen([sys.executable, "-m", "firmware_interface.emulator.forkserver", path],
                                  stdin=subprocess.PIPE, stdout=subprocess.PIPE, start_new_session=True)
        assert server.stdin is not None and server.stdout is not None
        before = os.environ.get(FORKSERVER_ENV)
        try:
            if server.stdout.readline() != b"ready\n":  # its flight code is loaded
                raise RuntimeError(f"the emulator fork server ended at its start (exit {server.wait()})")
            os.environ[FORKSERVER_ENV] = path
            yield path
        finally:
            if before is None:
                os.environ.pop(FORKSERVER_ENV, None)
            else:
                os.environ[FORKSERVER_ENV] = before
            server.stdin.close()  # its end of file: it stops
            try:
                server.wait(5.0)
            except subprocess.TimeoutExpired:
                server.kill()
                server.wait()


def warm_emulators_for_this_process() -> None:
    """A fork server for every emulator this process, and any process it starts, starts from now on (a sweep's
    worker flying sample after sample): started once, unless one is named already (`FORKSERVER_ENV`), and ended
    with the process (at its exit, or by its pipe's end when it is killed)."""
    if os.environ.get(FORKSERVER_ENV):
        return
    server = contextlib.ExitStack()
    server.enter_context(emulator_forkserver())
    atexit.register(server.close)
