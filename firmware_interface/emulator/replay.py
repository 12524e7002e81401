"""A flight's link replayed into an emulator in this process: the bench's frames from the run's tlog, fed one read
at a time as the emulator read them in the flight, and its answers compared with what it sent then.

Why: what the emulator sends is meant to depend only on the bytes it reads, never on the wall clock or on how the
kernel split the bytes into reads (the bench's recordings are bit for bit the same run after run because of it).
A replay shows that for a whole flight in about a second, with no pty, no bench and no other process, and times
the emulator's own handling of a real flight's mix of steps (`benchmarks/emulator_step.py`'s last line)."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from firmware_interface.emulator.config import load_config
from firmware_interface.emulator.firmware import EmulatedBoard
from firmware_interface.emulator.warm_up import compile_flight_code
from firmware_interface.link import Link, LinkLost
from firmware_interface.link.scanner import STX_V2
from firmware_interface.link.tlog import read_tlog_frames

BOARD_COMPONENT = 1  # the emulator's frames: its system id and component 1 (`EmulatedBoard`)


@dataclass(frozen=True)
class Replay:
    reads: int  # the bench's frames between two of the board's writes, one read each
    sent: bytes  # what the emulator answered now
    sent_in_flight: bytes  # what it answered in the flight
    handling_s: np.ndarray  # each read's handling, its answer written, in seconds

    @property
    def first_difference(self) -> int | None:
        """The first byte where the answers differ (None: none)."""
        if self.sent == self.sent_in_flight:
            return None
        return next((k for k, (a, b) in enumerate(zip(self.sent, self.sent_in_flight, strict=False)) if a != b),
                    min(len(self.sent), len(self.sent_in_flight)))


class _RecordedReads:
    """A transport that hands out the recorded reads in order and keeps what is written."""

    name = "a recorded flight"

    def __init__(self, reads: list[bytes]) -> None:
        self.reads, self.next, self.written = reads, 0, bytearray()

    def read(self, timeout_s: float) -> bytes:
        if self.next == len(self.reads):
            raise LinkLost("the recording ends")
        self.next += 1
        return self.reads[self.next - 1]

    def write(self, data: bytes) -> None:
        self.written += data

    def close(self) -> None:
        """Nothing to close."""


def replay_run(run_dir: Path) -> Replay:
    """Replay an emulator run's directory (its `emulator.yaml` and `link.tlog`)."""
    config = load_config(run_dir / "emulator.yaml")
    compile_flight_code(config)
    board_ids = bytes((config.system_id, BOARD_COMPONENT))
    reads: list[bytes] = []
    sent_in_flight, bench = bytearray(), bytearray()
    for frame in read_tlog_frames(run_dir / "link.tlog"):
        if (frame[5:7] if frame[0] == STX_V2 else frame[3:5]) == board_ids:
            sent_in_flight += frame
            if bench:
                reads.append(bytes(bench))
                bench.clear()
        else:
            bench += frame
    if bench:
        reads.append(bytes(bench))
    transport = _RecordedReads(reads)
    board = EmulatedBoard(Link(transport), config, repeat_boot_heartbeat=False)  # as `hil run` starts it
    handling_s = []
    try:
        while True:
            started = time.perf_counter()
            board.serve_once(0.0)
            handling_s.append(time.perf_counter() - started)
    except LinkLost:
        pass
    return Replay(len(reads), bytes(transport.written), bytes(sent_in_flight), np.array(handling_s))
