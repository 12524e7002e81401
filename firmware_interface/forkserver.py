"""The emulator fork server's wire, between the bench (`hil.boards.forked_emulator`) and the server
(`firmware_interface.emulator.forkserver`).

Why a fork server: an emulator's own start is ~0.8 s of CPU (numba's start and loading the compiled flight code),
paid again by every run. A process that starts many (a test suite, a CI job flying scenarios one `hil run` at a
time) can keep one warm server, whose forks answer in a few ms. The server's socket path is given to the benches in
`FORKSERVER_ENV`; without it every emulator is a fresh process, as before. A forked emulator has the server's
environment, not its bench's: the emulator reads none of its own (numba's cache location is read once, at load).

On a Unix stream socket, one connection per emulator: the bench sends one request (a JSON line with the emulator's
arguments and working directory, the log file's descriptor passed with it); the server answers `pid N` once the
child is forked and `exit C` when it has ended (C as `subprocess.Popen.returncode`: -N for a signal), then closes.
"""

from __future__ import annotations

import json
import socket

FORKSERVER_ENV = "HIL_EMULATOR_FORKSERVER"
_REQUEST_MAX = 1 << 16


def send_request(conn: socket.socket, args: list[str], cwd: str, log_fd: int) -> None:
    """Ask for an emulator run with `args` (the emulator's command-line arguments) in `cwd`, writing to `log_fd`."""
    socket.send_fds(conn, [json.dumps({"args": args, "cwd": cwd}).encode() + b"\n"], [log_fd])


def receive_request(conn: socket.socket) -> tuple[list[str], str, int]:
    """The arguments, working directory and log descriptor of one request (ValueError: not a whole request)."""
    data, fds, _, _ = socket.recv_fds(conn, _REQUEST_MAX, 1)
    if len(fds) != 1 or not data.endswith(b"\n"):
        for fd in fds:
            socket.close(fd)
        raise ValueError("a request is one JSON line with one log file descriptor")
    request = json.loads(data)
    return [str(a) for a in request["args"]], str(request["cwd"]), fds[0]


def pid_line(pid: int) -> bytes:
    return f"pid {pid}\n".encode()


def exit_line(returncode: int) -> bytes:
    return f"exit {returncode}\n".encode()


def parse_lines(data: bytes) -> dict[str, int]:
    """The server's whole answer lines read so far: {"pid": N, "exit": C}, the keys it has sent."""
    answers = {}
    for line in data.decode().split("\n")[:-1]:
        key, _, value = line.partition(" ")
        if key in ("pid", "exit") and value.lstrip("-").isdigit():
            answers[key] = int(value)
    return answers
