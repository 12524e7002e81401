"""A warm parent for emulators: `python -m firmware_interface.emulator.forkserver SOCKET`.

It imports the emulator and loads every controller's compiled flight code once, then forks an emulator for each
request on SOCKET (`firmware_interface.forkserver`: the wire). A fork starts with all of that done, so its first
heartbeat comes in ms instead of the ~0.8 s of CPU a fresh emulator spends; it then runs exactly what
`python -m firmware_interface.emulator ARGS` runs, in a session of its own, writing to the log it was given.

The server lives as long as whoever started it: it ends when its standard input reaches end of file (its
starter closed the pipe or died), and an emulator it forked outlives it only as long as its bench holds the pty.
"""

from __future__ import annotations

import contextlib
import os
import select
import signal
import socket
import sys
import traceback

from firmware_interface.emulator.__main__ import main as emulator_main
from firmware_interface.emulator.config import build_config
from firmware_interface.emulator.control.registry import CONTROLLERS
from firmware_interface.emulator.warm_up import exercise_flight_code
from firmware_interface.forkserver import exit_line, pid_line, receive_request

_REAP_EVERY_S = 0.05  # how soon an emulator's end is told to its bench (which also sees its pty close)


def serve(listener: socket.socket) -> None:
    """Fork an emulator for each request until standard input ends; tell each requester its pid and exit code."""
    children: dict[int, socket.socket] = {}
    while True:
        ready, _, _ = select.select([listener, sys.stdin.fileno()], [], [], _REAP_EVERY_S)
        _reap(children)
        if sys.stdin.fileno() in ready and not os.read(sys.stdin.fileno(), 4096):
            return
        if listener in ready:
            conn, _ = listener.accept()
            try:
                args, cwd, log_fd = receive_request(conn)
            except (OSError, ValueError) as exc:
                print(f"forkserver: a bad request ({exc})", file=sys.stderr, flush=True)
                conn.close()
                continue
            pid = os.fork()
            if pid == 0:
                _run_emulator(args, cwd, log_fd, [listener, conn, *children.values()])
            os.close(log_fd)
            _tell(conn, pid_line(pid))
            children[pid] = conn


def _run_emulator(args: list[str], cwd: str, log_fd: int, inherited: list[socket.socket]) -> None:
    """The forked child: the emulator's own process from here on. Never returns."""
    code = 1
    try:
        for sock in inherited:
            sock.close()
        os.setsid()  # as the bench's Popen(start_new_session=True): a terminal's Ctrl-C reaches the bench only
        os.dup2(log_fd, 1)
        os.dup2(log_fd, 2)
        os.close(log_fd)
        null = os.open(os.devnull, os.O_RDONLY)
        os.dup2(null, 0)
        os.close(null)
        os.chdir(cwd)
        code = emulator_main(args)
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 1
    except BaseException:
        traceback.print_exc()
    finally:
        with contextlib.suppress(Exception):
            sys.stdout.flush()
            sys.stderr.flush()
        os._exit(code)


def _reap(children: dict[int, socket.socket]) -> None:
    while children:
        try:
            pid, status = os.waitpid(-1, os.WNOHANG)
        except ChildProcessError:
            return
        if pid == 0:
            return
        conn = children.pop(pid, None)
        if conn is not None:
            _tell(conn, exit_line(os.waitstatus_to_exitcode(status)))
            conn.close()


def _tell(conn: socket.socket, line: bytes) -> None:
    """A requester that has gone (its bench ended) is nobody to tell."""
    with contextlib.suppress(OSError):
        conn.sendall(line)


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 1:
        print("usage: python -m firmware_interface.emulator.forkserver SOCKET", file=sys.stderr)
        return 2
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # its starter's Ctrl-C ends the starter, and then it
    for controller in CONTROLLERS:
        exercise_flight_code(build_config({"controller": controller}))
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    listener.bind(args[0])
    listener.listen(16)
    print("ready", flush=True)
    try:
        serve(listener)
    finally:
        listener.close()
        with contextlib.suppress(OSError):
            os.unlink(args[0])
            os.rmdir(os.path.dirname(os.path.abspath(args[0])))  # its directory, when nothing else is left in it
    return 0


if __name__ == "__main__":
    sys.exit(main())
