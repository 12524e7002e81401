"""MAVLink link: transports, a robust frame scanner, a fast encoder, and `Link` on top."""

from firmware_interface.link.connection import Connection, parse_connection
from firmware_interface.link.errors import LinkError, LinkLost
from firmware_interface.link.link import FrameTap, Link, Message, open_link
from firmware_interface.link.pty import PtyPair, open_pty_pair
from firmware_interface.link.scanner import FrameScanner, Reject
from firmware_interface.link.tlog import TlogWriter
from firmware_interface.link.transports import FdTransport, TcpServerTransport

__all__ = [
    "Connection", "FdTransport", "FrameScanner", "FrameTap", "Link", "LinkError", "LinkLost", "Message", "PtyPair",
    "Reject", "TcpServerTransport", "TlogWriter", "open_link", "open_pty_pair",
    "parse_connection",
]
