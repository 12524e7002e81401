"""A byte scanner that finds MAVLink v1/v2 frames on a noisy line.

pymavlink's stream parser trusts LEN and consumes a whole span before validating it,
so one fake `FD FF` can swallow 267 bytes of good frames (docs/px4_protocol.md §2.2).
This scanner validates everything it can as soon as the bytes are there (LEN against
the message's full payload, known id, incompat flags, CRC with CRC_EXTRA) and on any
failure drops only the start byte and rescans from the next one (same section).
"""

from __future__ import annotations

import re
from collections import Counter
from enum import StrEnum

import fastcrc
import numpy as np

from firmware_interface.link.dialect import SPECS
from firmware_interface.link.frame_packing import (
    CRC_LEN,
    INCOMPAT_SIGNED,
    OVERHEAD,
    PAYLOAD,
    PAYLOAD_V1,
    SIGNATURE_LEN,
    STX_V2,
)
from firmware_interface.link.frame_scan import CRC_EXTRA, FRAMES_PER_CALL, FULL_PAYLOAD, clean_frames

V2_HEADER, V1_HEADER = PAYLOAD, PAYLOAD_V1
_START = re.compile(rb"[\xfd\xfe]")
_crc16 = fastcrc.crc16.mcrf4xx


class Reject(StrEnum):
    """Why bytes were not accepted as a frame; each is one counter."""

    GARBAGE = "garbage_bytes"  # bytes between frames that start nothing
    BAD_CRC = "bad_crc"
    BAD_LENGTH = "bad_length"  # LEN 0 or above the message's full payload
    UNKNOWN_ID = "unknown_id"
    BAD_FLAGS = "bad_flags"  # unknown incompat_flags bits
    TIMEOUT = "timeout"  # a partial frame waited too long for its bytes
    TRUNCATED = "truncated"  # a partial frame with a complete valid frame behind it


_NEED_MORE = -1


MAX_FRAME_BYTES = 280  # a signed MAVLink 2 frame with a 255-byte payload
BITS_PER_BYTE = 10  # 8N1: start, 8 data, stop
DEFAULT_PARTIAL_TIMEOUT_S = 0.02


def partial_timeout_for(baud: int | None) -> float:
    """How long a partial frame may wait for its bytes: twice the longest frame's transfer time at the
    line's baud rate, and never less than 20 ms (a pty or socket has no byte rate: None)."""
    if not baud:
        return DEFAULT_PARTIAL_TIMEOUT_S
    return max(DEFAULT_PARTIAL_TIMEOUT_S, 2 * MAX_FRAME_BYTES * BITS_PER_BYTE / baud)


class FrameScanner:
    """Feed bytes in, get complete, CRC-checked frames (as bytes) out, in order."""

    def __init__(self, partial_timeout_s: float = DEFAULT_PARTIAL_TIMEOUT_S) -> None:
        self.partial_timeout_s = partial_timeout_s
        self.counts: Counter[str] = Counter({r.value: 0 for r in Reject})
        self.frames_accepted = 0
        self._buf = bytearray()
        self._partial_since: float | None = None
        self._ends = np.zeros(FRAMES_PER_CALL, dtype=np.int64)  # where `clean_frames` found each frame's end

    def feed(self, data: bytes, now_s: float) -> list[bytes]:
        """Add bytes received at `now_s` (monotonic seconds); return the frames now complete. With nothing held
        from an earlier read, the whole frames the read starts with are taken by compiled code (`frame_scan`);
        the rest, if any, goes the general way."""
        if self._buf or len(data) < OVERHEAD:
            return self._scan(data, now_s)
        data = bytes(data)
        ends: list[int] = []
        count = FRAMES_PER_CALL
        while count == FRAMES_PER_CALL:
            count = clean_frames(data, ends[-1] if ends else 0, FULL_PAYLOAD, CRC_EXTRA, self._ends)
            ends += self._ends[:count].tolist()
        if not ends:
            return self._scan(data, now_s)
        self.frames_accepted += len(ends)
        self._partial_since = None
        whole = ends[-1] == len(data)
        if whole and len(ends) == 1:  # the lockstep reply: one frame, the whole read
            return [data]
        frames = [data[start:end] for start, end in zip([0, *ends], ends, strict=False)]
        return frames if whole else frames + self._scan(data[ends[-1]:], now_s)

    def _scan(self, data: bytes, now_s: float) -> list[bytes]:
        """The general way: from any byte, every start byte checked, rejected bytes counted by reason."""
        buf = self._buf
        buf += data
        frames: list[bytes] = []
        pos = 0
        while True:
            match = _START.search(buf, pos)
            start = match.start() if match else len(buf)
            if start > pos:
                self.counts[Reject.GARBAGE] += start - pos
                self._partial_since = None
            pos = start
            if not match:
                break
            result = self._check(buf, pos)
            if isinstance(result, Reject):
                self.counts[result] += 1
                pos += 1
                self._partial_since = None
            elif result != _NEED_MORE:
                frames.append(bytes(buf[pos : pos + result]))
                self.frames_accepted += 1
                pos += result
                self._partial_since = None
            elif self._complete_frame_after(buf, pos + 1):
                self.counts[Reject.TRUNCATED] += 1
                pos += 1
                self._partial_since = None
            else:
                if self._partial_since is None:
                    self._partial_since = now_s
                if now_s - self._partial_since <= self.partial_timeout_s:
                    break
                self.counts[Reject.TIMEOUT] += 1
                pos += 1
                self._partial_since = None
        del buf[:pos]
        return frames

    def poll(self, now_s: float) -> list[bytes]:
        """Apply the partial-frame timeout when no bytes arrived."""
        return self.feed(b"", now_s)

    @property
    def pending_bytes(self) -> int:
        return len(self._buf)

    def _complete_frame_after(self, buf: bytearray, pos: int) -> bool:
        for match in _START.finditer(buf, pos):
            result = self._check(buf, match.start())
            if not isinstance(result, Reject) and result != _NEED_MORE:
                return True
        return False

    @staticmethod
    def _check(buf: bytearray, p: int) -> int | Reject:
        """Frame length if a valid frame starts at p, _NEED_MORE, or why it cannot."""
        available = len(buf) - p
        v2 = buf[p] == STX_V2
        header = V2_HEADER if v2 else V1_HEADER
        if available < 2:
            return _NEED_MORE
        length = buf[p + 1]
        if length == 0:
            return Reject.BAD_LENGTH
        signature = 0
        if v2:
            if available < 3:
                return _NEED_MORE
            flags = buf[p + 2]
            if flags & ~INCOMPAT_SIGNED:
                return Reject.BAD_FLAGS
            if flags & INCOMPAT_SIGNED:
                signature = SIGNATURE_LEN
        if available < header:
            return _NEED_MORE
        msgid = (buf[p + 7] | buf[p + 8] << 8 | buf[p + 9] << 16) if v2 else buf[p + 5]
        spec = SPECS.get(msgid)
        if spec is None:
            return Reject.UNKNOWN_ID
        if length > spec.full_payload:
            return Reject.BAD_LENGTH
        total = header + length + CRC_LEN + signature
        if available < total:
            return _NEED_MORE
        crc_end = p + header + length
        crc = _crc16(bytes(buf[p + 1 : crc_end]) + bytes((spec.crc_extra,)))
        if crc != buf[crc_end] | buf[crc_end + 1] << 8:
            return Reject.BAD_CRC
        return total
