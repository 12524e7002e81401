"""The board kinds by the scheme that names them, as a user writes a board: `emulator`, `px4:DIR`,
`px4-hitl:DIR`, `port:CONNECTION` (serial → a Pixhawk; tcpin:/udp… → a PX4 SITL started by hand). `hil run`'s
--port/--px4/--px4-hitl and the pytest plugin's --hil-board come here; adding a kind is its module plus one line in
`KINDS`."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from firmware_interface.link import LinkError, parse_connection
from hil.boards.emulator import EmulatorTarget
from hil.boards.px4 import Px4Build, Px4SetupError
from hil.boards.px4_hitl import Px4HitlTarget
from hil.boards.px4_sitl import Px4SitlTarget
from hil.boards.serial_board import SerialBoardTarget
from hil.boards.sitl_port import SitlPortTarget
from hil.boards.target import BoardTarget


class BoardSpecError(ValueError):
    """A board named wrongly: the message is one line naming what is wrong."""


@dataclass(frozen=True)
class BoardOptions:
    """What a user may add to the board's name: options of the attached kinds, and how the board was named (the
    CLI option or the scheme) for messages."""

    mavlink: str | None = None  # a separate command link (a PX4 SITL started by hand)
    baud: int | None = None  # serial rate where the connection names none
    connect_timeout_s: float | None = None  # how long the board has to speak (and a lockstep one to boot)
    named_by: str = "board"


def _emulator(rest: str, options: BoardOptions) -> BoardTarget:
    if rest:
        raise BoardSpecError(f"{options.named_by}: the emulator takes no argument (got '{rest}')")
    return EmulatorTarget(options.connect_timeout_s)


def _px4_build(rest: str, options: BoardOptions) -> Px4Build:
    try:
        return Px4Build.locate(rest, options.named_by)
    except Px4SetupError as exc:
        raise BoardSpecError(str(exc)) from exc


def _attached(rest: str, options: BoardOptions) -> BoardTarget:
    for option, text in ((options.named_by, rest), ("--mavlink", options.mavlink)):
        try:
            if text is not None:
                parse_connection(text, options.baud)
        except LinkError as exc:
            raise BoardSpecError(f"{option} {text}: {exc}") from exc
    connection = parse_connection(rest, options.baud)
    if connection.kind == "serial":
        return SerialBoardTarget(rest, options.baud, options.connect_timeout_s)
    return SitlPortTarget(rest, options.mavlink, options.connect_timeout_s)


KINDS: dict[str, Callable[[str, BoardOptions], BoardTarget]] = {
    "emulator": _emulator,
    "px4": lambda rest, options: Px4SitlTarget(_px4_build(rest, options), options.connect_timeout_s),
    "px4-hitl": lambda rest, options: Px4HitlTarget(_px4_build(rest, options), options.connect_timeout_s),
    "port": _attached,
}


def board_target(spec: str, options: BoardOptions | None = None) -> BoardTarget:
    """The board `spec` names (SCHEME or SCHEME:ARGUMENT); BoardSpecError in one line otherwise."""
    options = options or BoardOptions()
    scheme, _, rest = spec.partition(":")
    if scheme not in KINDS:
        raise BoardSpecError(f"{options.named_by} {spec}: unknown board kind '{scheme}' (expected "
                             f"{', '.join(f'{k}' if k == 'emulator' else f'{k}:...' for k in KINDS)})")
    return KINDS[scheme](rest, options)
