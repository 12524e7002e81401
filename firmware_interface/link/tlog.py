"""A telemetry log of a link, as QGroundControl and MAVProxy write it (`.tlog`): each MAVLink frame as
it went over the wire, both directions, after an 8-byte big-endian timestamp in µs since the Unix
epoch. pymavlink's `mavutil.mavlink_connection("x.tlog")` and `mavlogdump.py` read it.
"""

from __future__ import annotations

import struct
import time
from collections.abc import Sequence
from pathlib import Path

_STAMP = struct.Struct(">Q")


class TlogWriter:
    """Appends frames with strictly increasing timestamps (frames of one microsecond keep their order)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self._file = open(path, "wb", buffering=1 << 16)  # noqa: SIM115 - closed in close()
        self._last_us = 0
        self.frames = 0

    def __call__(self, frames: Sequence[bytes]) -> None:
        """The frames of one write or one read, stamped now (each a microsecond after the one before)."""
        if self._file.closed:
            return
        now_us = max(time.time_ns() // 1000, self._last_us + 1)
        self._last_us = now_us + len(frames) - 1
        self._file.write(b"".join(_STAMP.pack(now_us + k) + frame for k, frame in enumerate(frames)))
        self.frames += len(frames)

    def close(self) -> None:
        if not self._file.closed:
            self._file.close()
