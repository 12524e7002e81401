"""The whole, valid MAVLink 2 frames at the start of a read, found by compiled code: the scanner's path for a clean
stream, the lockstep link's every read.

In Python, finding a frame costs ~1.5 µs alone and three times that inside a flight (the start byte searched for,
the header checked field by field, the bytes copied for the checksum), and each side of a lockstep step reads
every step (the board's reply; on tick steps with its telemetry streams, six to eight frames). Here one call walks
the frames from the read's first byte with the same checks as `FrameScanner` (LEN within the message's full
payload and not 0, a known id, no incompatibility flag, the X.25 checksum with CRC_EXTRA) and stops at the first
byte that is not the start of one: garbage, a MAVLink 1 or signed frame, a rejected or unfinished frame. What it
stops at is the scanner's general path, so what comes out is what the general path alone gives.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from firmware_interface.compiled_code import CompiledCode
from firmware_interface.link import frame_packing
from firmware_interface.link.dialect import SPECS
from firmware_interface.link.frame_packing import OVERHEAD, PAYLOAD, STX_V2, crc_x25

FRAME_SCAN = CompiledCode("frame-scan", (Path(__file__), Path(frame_packing.__file__)))
FRAMES_PER_CALL = 64  # ends a call reports; a read with more takes more calls

# Indexed by message id: the most LEN can be (-1: an id the scanner does not know), and CRC_EXTRA.
FULL_PAYLOAD = np.full(max(SPECS) + 1, -1, dtype=np.int64)
CRC_EXTRA = np.zeros(max(SPECS) + 1, dtype=np.int64)
for _msgid, _spec in SPECS.items():
    FULL_PAYLOAD[_msgid], CRC_EXTRA[_msgid] = _spec.full_payload, _spec.crc_extra


@FRAME_SCAN.compiled
def clean_frames(data: bytes, start: int, full_payload: np.ndarray, crc_extra: np.ndarray, ends: np.ndarray) -> int:
    """How many whole, valid, unsigned MAVLink 2 frames follow each other from `data[start]` (at most `ends.size`),
    their ends written to `ends`. `data` is the read's bytes as they are (numba reads a bytes object as a read-only
    uint8 buffer: a call costs ~0.6 µs, against ~1.3 µs with an array made of them first)."""
    count, at, size = 0, start, len(data)
    while count < ends.size and size - at >= OVERHEAD:
        length = int(data[at + 1])
        if data[at] != STX_V2 or length == 0 or data[at + 2] != 0:
            break
        msgid = int(data[at + 7]) | int(data[at + 8]) << 8 | int(data[at + 9]) << 16
        end = at + OVERHEAD + length
        if msgid >= full_payload.size or length > full_payload[msgid] or end > size:
            break
        if crc_x25(data, at + 1, end - 2, crc_extra[msgid]) != (int(data[end - 2]) | int(data[end - 1]) << 8):
            break
        ends[count] = end
        count += 1
        at = end
    return count


def warm_up() -> None:
    """`clean_frames` compiled (or loaded from its cache) now, not at a flight's first read."""
    clean_frames(bytes(PAYLOAD + 3), 0, FULL_PAYLOAD, CRC_EXTRA, np.zeros(FRAMES_PER_CALL, dtype=np.int64))
