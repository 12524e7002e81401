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
USAGE = ("use a serial device (/dev/ttyACM0, /dev/ttyACM0,921600 or serial:/dev/ttyACM0[:BAUD]), "
         "tcpin:HOST:PORT, tcp:HOST:PORT, udpin:HOST:PORT (or udp:HOST:PORT, as mavutil) or udpout:HOST:PORT")
_NET = re.compile(r"^(tcpin|tcp|udpin|udpout|udp):([^:]+):(\d{1,5})$")
_SERIAL = re.compile(r"^serial:(/[^:,]+)(?::(\d+))?$")
_DEVICE = re.compile(r"^(/[^:,]+)(?:,(\d+))?$")  # mavutil/MAVProxy: /dev/ttyACM0,921600


@dataclass(frozen=True)
class Connection:
    kind: Kind
    address: str  # device path or host
    number: int  # baud or port

    def __str__(self) -> str:
        return f"{self.kind}:{self.address}:{self.number}"


def parse_connection(text: str, baud: int | None = None) -> Connection:
    """Parse a connection string as PX4 users type them (mavutil's forms included); `baud` is the serial
    rate where the string names none. A one-line LinkError for anything else."""
    if (m := _DEVICE.match(text)) or (m := _SERIAL.match(text)):
        return Connection("serial", m.group(1), int(m.group(2) or baud or DEFAULT_BAUD))
    if m := _NET.match(text):
        port = int(m.group(3))
        if port > 65535:
            raise LinkError(f"bad port in '{text}': {port} is above 65535")
        kind = "udpin" if m.group(1) == "udp" else m.group(1)  # mavutil's udp: listens
        return Connection(kind, m.group(2), port)  # type: ignore[arg-type]
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
