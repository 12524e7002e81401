"""`Link`: MAVLink messages over any transport, through our frame scanner and encoder."""

from __future__ import annotations

import itertools
import time
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from typing import Any, Self, TypeAlias

import numpy as np
from pymavlink.dialects.v20 import common

from firmware_interface.link.connection import open_transport, parse_connection
from firmware_interface.link.dialect import PASSTHROUGH, frame_msgid
from firmware_interface.link.encoder import FrameEncoder, message_class
from firmware_interface.link.errors import LinkLost
from firmware_interface.link.faults import LinkFaults
from firmware_interface.link.light_messages import LIGHT
from firmware_interface.link.scanner import STX_V2, FrameScanner, partial_timeout_for
from firmware_interface.link.transports import SpinWait, Transport

Message: TypeAlias = Any  # a pymavlink MAVLink_message: pymavlink carries no type information
# sees every frame sent and every frame accepted, those of one write or one read together, e.g. a TlogWriter
FrameTap = Callable[[Sequence[bytes]], None]
# takes a read made of whole frames its user handles at once (a lockstep reply; a lockstep step's frames): the
# frames' ends in the read when it took them, () when the read goes the scanner's way
WholeFrameReader = Callable[[bytes], tuple[int, ...]]
# packs one frame at the start of a buffer: (buffer, seq, system id, component id, *fields) -> its length
Packer = Callable[..., int]
PACKED_MAX = 512  # bytes: the longest frame a packer writes (firmware_interface.hil_frames), with room


class Link:
    """Send and receive MAVLink messages; never blocks past the caller's timeout.

    Frames are found by `FrameScanner` (robust to noise) and decoded by pymavlink's
    message classes; outgoing frames come from `FrameEncoder`.
    """

    def __init__(self, transport: Transport, system_id: int = 1, component_id: int = 1,
                 partial_timeout_s: float | None = None, tap: FrameTap | None = None) -> None:
        self.transport = transport
        self.tap = tap
        self.faults: LinkFaults | None = None  # injected between the bench and the board (scenario faults.link)
        self.name = transport.name
        self.encoder = FrameEncoder(system_id, component_id)
        # a serial line's bytes arrive at its baud rate: a partial frame waits as long as a frame takes
        self.scanner = FrameScanner(partial_timeout_s if partial_timeout_s is not None
                                    else partial_timeout_for(getattr(transport, "baud", None)))
        self._decoder = common.MAVLink(None)
        self.decode_errors = 0
        # Ids the link's user reads; other valid frames are kept whole, undecoded (None: decode them all).
        # pymavlink's decode is ~20 us a frame, and PX4 streams ~400 frames per second its user never reads.
        self.decoded_ids: frozenset[int] | None = None
        self.ids_seen: set[int] = set()  # the message id of every valid frame received
        self.passthrough: list[bytes] = []  # valid frames kept whole: not read by the user, or unknown to pymavlink
        self.passed_through = 0
        self.whole_frame_reader: WholeFrameReader | None = None  # tried on each read before the scanner
        self.bytes_in = 0
        self.waited_s = 0.0  # wall time in reads that waited for bytes (a timeout > 0): the user's wait for its peer
        self.bytes_out = 0
        self.frames_out = 0
        self._closed = False
        self._batch: list[bytes] | None = None  # the pieces of the next write, when batching
        # the batch's frames for the tap, shown it once they are written (a block of frames with their ends, or one
        # frame): the tap (the run's tlog) then costs nothing before the write, which a lockstep step waits for
        self._tap_after_write: list[tuple[bytes, list[int]]] = []
        self._packed = np.zeros(PACKED_MAX, np.uint8)  # what `pack` writes into

    def send(self, message: str, /, **fields: Any) -> None:
        """Send one message by name, e.g. `send("HEARTBEAT", type=2, ...)`."""
        self.send_frame(self.encode(message, fields))

    def send_fields(self, message: str, fields: Mapping[str, Any]) -> None:
        self.send_frame(self.encode(message, fields))

    def encode(self, message: str, fields: Mapping[str, Any]) -> bytes:
        """One frame of this link's sender, numbered now: for a frame built ahead of when it is sent."""
        return self.encoder.encode(message_class(message), fields)

    def pack(self, packer: Packer, *fields: Any) -> bytes:
        """One frame of this link's sender from a compiled packer (`hil_frames.encode_*`), numbered now."""
        encoder = self.encoder
        size = packer(self._packed, encoder.seq, encoder.system_id, encoder.component_id, *fields)
        encoder.seq = (encoder.seq + 1) & 0xFF
        return self._packed[:size].tobytes()

    def send_frames(self, frames: np.ndarray, ends: np.ndarray, count: int) -> None:
        """`count` frames packed one after the other in `frames`, each ending at `ends[k]`, numbered from this
        link's sequence on (the packer took it): sent as `send_frame` sends each, in one piece when nothing
        watches or alters single frames."""
        self.encoder.seq = (self.encoder.seq + count) & 0xFF
        if self.faults is None and self._batch is not None:  # the common case: a step's frames into its write
            block = frames[:ends[count - 1]].tobytes()
            self._batch.append(block)
            self.bytes_out += len(block)
            self.frames_out += count
            if self.tap is not None:
                self._tap_after_write.append((block, ends[:count].tolist()))
            return
        start = 0
        for k in range(count):
            self.send_frame(frames[start:ends[k]].tobytes())
            start = int(ends[k])

    def send_frame(self, frame: bytes) -> None:
        self.bytes_out += len(frame)
        self.frames_out += 1
        wire = frame if self.faults is None else self.faults.outgoing(frame)
        if self._batch is not None:
            if self.tap is not None:
                self._tap_after_write.append((frame, [len(frame)]))
            self._batch.append(wire)
            return
        if self.tap is not None:
            self.tap((frame,))
        if wire:
            self.transport.write(wire)

    def begin_batch(self) -> None:
        """Collect the frames sent from now on and write them at `flush()` in one piece: the board then
        reads everything of one step together, whatever the scheduling."""
        self._batch = []

    def flush(self) -> None:
        batch, self._batch = self._batch, None
        tapped, self._tap_after_write = self._tap_after_write, []
        if batch:  # most often one piece, the step's frames: written as they are
            self.transport.write(batch[0] if len(batch) == 1 else b"".join(batch))
        if tapped and self.tap is not None:
            self.tap([block[a:b] for block, ends in tapped for a, b in itertools.pairwise([0, *ends])])

    def receive(self, timeout_s: float) -> list[Message]:
        """Messages that arrive within `timeout_s` (returns as soon as one batch is in)."""
        deadline = time.monotonic() + timeout_s
        while True:
            remaining = deadline - time.monotonic()
            if remaining > 0:
                reading = time.perf_counter()
                data = self.transport.read(remaining)
                self.waited_s += time.perf_counter() - reading
            else:
                data = self.transport.read(0.0)
            self.bytes_in += len(data)
            if self.faults is not None:
                data = self.faults.incoming_bytes(data)
            elif data and self._read_whole(data):
                return []
            frames = self.scanner.feed(data, time.monotonic())
            if self.faults is not None:
                frames = self.faults.incoming_frames(frames)
            if self.tap is not None and frames:
                self.tap(frames)
            if frames or remaining <= 0:
                return [m for m in (self._decode(f) for f in frames) if m is not None]

    def _read_whole(self, data: bytes) -> bool:
        """`data` taken by the whole-frame reader, with nothing held from an earlier read: its frames counted and
        tapped as frames the scanner accepted and its user decoded."""
        reader = self.whole_frame_reader
        if reader is None or self.scanner.pending_bytes:
            return False
        ends = reader(data)
        if not ends:
            return False
        self.scanner.frames_accepted += len(ends)
        frames = (data,) if len(ends) == 1 else [data[start:end] for start, end in zip((0, *ends), ends, strict=False)]
        self.ids_seen.update(map(frame_msgid, frames))
        if self.tap is not None:
            self.tap(frames)
        return True

    def _decode(self, frame: bytes) -> Message | None:
        msgid = frame_msgid(frame)
        self.ids_seen.add(msgid)
        if msgid in PASSTHROUGH or (self.decoded_ids is not None and msgid not in self.decoded_ids):
            self.passthrough.append(frame)
            self.passed_through += 1
            return None
        light = LIGHT.get(msgid)
        if light is not None and frame[0] == STX_V2:  # a message of every step: no pymavlink object
            return light(frame)
        try:
            return self._decoder.decode(bytearray(frame))
        except Exception:
            self.decode_errors += 1
            return None

    @property
    def counters(self) -> dict[str, int]:
        counts: Counter[str] = Counter(self.scanner.counts)
        counts.update(frames_in=self.scanner.frames_accepted, frames_out=self.frames_out,
                      bytes_in=self.bytes_in, bytes_out=self.bytes_out, decode_errors=self.decode_errors,
                      passed_through=self.passed_through)
        return dict(counts)

    def spin_wait(self) -> None:
        """Wait for what the peer sends by polling a while before sleeping (`SpinWait`), where the transport can
        (a pty, a serial port, TCP); a no-op elsewhere."""
        if hasattr(self.transport, "spin"):
            self.transport.spin = SpinWait()

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            self.transport.close()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def open_link(connection: str, system_id: int = 1, component_id: int = 1, tap: FrameTap | None = None,
              baud: int | None = None) -> Link:
    """Open a link from a connection string such as `/dev/ttyACM0` or `tcpin:127.0.0.1:4560`."""
    return Link(open_transport(parse_connection(connection, baud)), system_id, component_id, tap=tap)


__all__ = ["FrameTap", "Link", "LinkLost", "Message", "WholeFrameReader", "open_link"]
