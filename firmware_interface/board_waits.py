"""Commands that wait for the board's answer, for scripts, benchmarks and tests that talk to a board directly.
The bench never waits: its pilots ask each step until the answer is in the session's report."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from pymavlink.dialects.v20.common import MAV_RESULT_ACCEPTED

from firmware_interface.board import BoardSession
from firmware_interface.board_requests import ARM, DISARM, OFFBOARD, BoardError, Request


def command(session: BoardSession, request: Request, timeout_s: float = 3.0,
            pump: Callable[[], Any] | None = None) -> int:
    """COMMAND_LONG, waiting for its COMMAND_ACK; returns MAV_RESULT. `pump` keeps a
    lockstep simulation stepping while we wait (PX4 SITL's clock only moves with sensors)."""
    command = request.command
    deadline = session.clock() + timeout_s
    last_sent = -1e9
    session.report.acks.pop(command, None)
    while command not in session.report.acks:
        now = session.clock()
        if now > deadline:
            raise BoardError(f"no COMMAND_ACK for command {command} within {timeout_s:g} s")
        if now - last_sent > 0.5:
            session.ask(request)
            last_sent = now
        if pump is not None:
            pump()
        session.service()
        session.poll(0.0 if pump is not None else 0.02)
    return session.report.acks[command]


def arm(session: BoardSession, armed: bool = True, **kwargs: Any) -> None:
    """Arm (or disarm) and wait for the board to accept; BoardError with its last texts otherwise."""
    result = command(session, ARM if armed else DISARM, **kwargs)
    if result != MAV_RESULT_ACCEPTED:
        texts = "; ".join(t for _, t in session.report.status_texts[-3:])
        said = f": {texts}" if texts else ""
        raise BoardError(f"{'arming' if armed else 'disarming'} refused (MAV_RESULT {result}){said}")


def set_offboard(session: BoardSession, **kwargs: Any) -> None:
    result = command(session, OFFBOARD, **kwargs)
    if result != MAV_RESULT_ACCEPTED:
        raise BoardError(f"offboard mode refused (MAV_RESULT {result})")
