"""A raw pseudo-terminal pair: the bench holds the master, a board process opens the slave path."""

from __future__ import annotations

import os
import tty
from dataclasses import dataclass

from firmware_interface.link.transports import FdTransport


@dataclass
class PtyPair:
    master: FdTransport
    slave_path: str
    slave_fd: int  # kept open until the board has opened the path; `release_slave` then closes it

    def release_slave(self) -> None:
        """Close our slave copy so that the board closing its end reads as LinkLost on the master."""
        if self.slave_fd >= 0:
            os.close(self.slave_fd)
            self.slave_fd = -1


def open_pty_pair() -> PtyPair:
    master_fd, slave_fd = os.openpty()
    # Raw at once: with the default line discipline the pty would echo our bytes back
    # and translate CR/LF, corrupting binary MAVLink.
    tty.setraw(slave_fd)
    tty.setraw(master_fd)
    path = os.ttyname(slave_fd)
    return PtyPair(FdTransport(master_fd, f"pty:{path}"), path, slave_fd)
