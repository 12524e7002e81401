"""Connection strings as PX4 users know them from mavutil and jMAVSim."""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Literal

from firmware_interface.link.errors import LinkError
from firmware_interface.link.transports import (
    SerialTransport,
    TcpClientTransport,
    TcpServerTransport,
    Transport,
    UdpTransport,
)

DEFAULT_BAUD = 921600
Kind = Literal["serial", "tcpin", "tcp", "udpin", "udpout"]
USAGE = ("use a serial device (/dev/ttyACM0 or serial:/dev/ttyACM0[:BAUD]), "
         "tcpin:HOST:PORT, tcp:HOST:PORT, udpin:HOST:PORT or udpout:HOST:PORT")
_NET = re.compile(r"^(tcpin|tcp|udpin|udpout):([^:]+):(\d{1,5})$")
_SERIAL = re.compile(r"^serial:(/[^:]+)(?::(\d+))?$")


@dataclass(frozen=True)
class Connection:
    kind: Kind
    address: str  # device path or host
    number: int  # baud or port

    def __str__(self) -> str:
        return f"{self.kind}:{self.address}:{self.number}"


def parse_connection(text: str) -> Connection:
    """Parse a connection string; a one-line LinkError for anything else."""
    if text.startswith("/"):
        return Connection("serial", text, DEFAULT_BAUD)
    if m := _SERIAL.match(text):
        return Connection("serial", m.group(1), int(m.group(2) or DEFAULT_BAUD))
    if m := _NET.match(text):
        port = int(m.group(3))
        if port > 65535:
            raise LinkError(f"bad port in '{text}': {port} is above 65535")
        return Connection(m.group(1), m.group(2), port)  # type: ignore[arg-type]
    raise LinkError(f"unsupported connection '{text}': {USAGE}")


def open_transport(connection: Connection) -> Transport:
    match connection.kind:
        case "serial":
            return SerialTransport(connection.address, connection.number)
        case "tcpin":
            return TcpServerTransport(connection.address, connection.number)
        case "tcp":
            return TcpClientTransport(connection.address, connection.number)
        case "udpin":
            return UdpTransport(connection.address, connection.number, listen=True)
        case "udpout":
            return UdpTransport(connection.address, connection.number, listen=False)
