"""What the bench asks of a board (a COMMAND_LONG or a parameter), and the forms that wait for the answer, for
scripts and tests: the bench itself never waits, it asks each step until the answer is in the session's report."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from pymavlink.dialects.v20.common import (
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_CMD_DO_SET_MODE,
    MAV_CMD_NAV_LAND,
    MAV_RESULT_ACCEPTED,
)

from firmware_interface import hil_codec as codec
from firmware_interface.link import LinkError
from firmware_interface.px4_modes import FORCE_DISARM_MAGIC, PX4_MAIN_MODE_OFFBOARD

if TYPE_CHECKING:
    from firmware_interface.board import BoardSession


class BoardError(LinkError):
    """The board did not answer as expected (no heartbeat, command refused, silent)."""


@dataclass(frozen=True)
class Request:
    """A COMMAND_LONG and its parameters (`BoardSession.ask`); its COMMAND_ACK lands in the session's report."""

    command: int
    params: tuple[float, ...] = ()


@dataclass(frozen=True)
class ParamSet:
    """A PARAM_SET: a float parameter (REAL32) or an int one (INT32); the board answers with PARAM_VALUE
    (`BoardReport.params`)."""

    name: str
    value: float | int


ARM = Request(MAV_CMD_COMPONENT_ARM_DISARM, (1.0,))
DISARM = Request(MAV_CMD_COMPONENT_ARM_DISARM, (0.0,))
FORCE_DISARM = Request(MAV_CMD_COMPONENT_ARM_DISARM, (0.0, float(FORCE_DISARM_MAGIC)))  # also in the air
OFFBOARD = Request(MAV_CMD_DO_SET_MODE, (float(codec.MODE_FLAG_CUSTOM), float(PX4_MAIN_MODE_OFFBOARD)))
LAND = Request(MAV_CMD_NAV_LAND)  # PX4's AUTO_LAND where the vehicle is


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
