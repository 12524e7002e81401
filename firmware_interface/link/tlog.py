"""A telemetry log of a link, as QGroundControl and MAVProxy write it (`.tlog`): each MAVLink frame as
it went over the wire, both directions, after an 8-byte big-endian timestamp in µs since the Unix
epoch. pymavlink's `mavutil.mavlink_connection("x.tlog")` and `mavlogdump.py` read it.
"""

from __future__ import annotations

import struct
import time
from collections.abc import Sequence
from pathlib import Path

from firmware_interface.link.scanner import CRC_LEN, INCOMPAT_SIGNED, SIGNATURE_LEN, STX_V2, V1_HEADER, V2_HEADER

_STAMP = struct.Struct(">Q")


class TlogWriter:
    """Appends frames with strictly increasing timestamps (frames of one microsecond keep their order).

    A call stamps its frames and holds them; `write_held` writes them to the file. The bench calls it after a
    step's frames are sent, so that the reply it reads in lockstep does not wait for a file write (~3 µs a step
    on the round trip, measured); every HOLD_RECORDS calls and `close` write them too."""

    HOLD_RECORDS = 256

    def __init__(self, path: Path) -> None:
        self.path = path
        self._file = open(path, "wb", buffering=1 << 16)  # noqa: SIM115 - closed in close()
        self._last_us = 0
        self._held: list[tuple[int, Sequence[bytes]]] = []  # (first frame's stamp, the frames of one call)
        self.frames = 0

    def __call__(self, frames: Sequence[bytes]) -> None:
        """The frames of one write or one read, stamped now (each a microsecond after the one before)."""
        if self._file.closed:
            return
        now_us = max(time.time_ns() // 1000, self._last_us + 1)
        self._last_us = now_us + len(frames) - 1
        self._held.append((now_us, frames))
        self.frames += len(frames)
        if len(self._held) >= self.HOLD_RECORDS:
            self.write_held()

    def write_held(self) -> None:
        held, self._held = self._held, []
        if held and not self._file.closed:
            self._file.write(b"".join(_STAMP.pack(stamp_us + k) + frame for stamp_us, frames in held
                                      for k, frame in enumerate(frames)))

    def close(self) -> None:
        if not self._file.closed:
            self.write_held()
            self._file.close()


def read_tlog_frames(path: Path) -> list[bytes]:
    """The frames of a tlog this module wrote, in order (their stamps dropped)."""
    data, at, frames = path.read_bytes(), 0, []
    while at + _STAMP.size < len(data):
        at += _STAMP.size
        size = V1_HEADER + data[at + 1] + CRC_LEN
        if data[at] == STX_V2:
            size += V2_HEADER - V1_HEADER + (SIGNATURE_LEN if data[at + 2] & INCOMPAT_SIGNED else 0)
        frames.append(data[at:at + size])
        at += size
    return frames
