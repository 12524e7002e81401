"""Faults injected on a link, between the bench and the board: frame loss (single or in bursts), added
latency with jitter, byte corruption, and outages, each between two times and in one direction or both.

The bench sets the clock (`now_s`, simulated seconds; `window_s`, the time the fault windows refer to)
every step. Outgoing frames wait in a queue until due; incoming bytes are corrupted before the frame
scanner sees them (so the scanner's recovery is part of the test), and incoming frames are dropped or
held after it. Every injection is counted, by direction and kind.
"""

from __future__ import annotations

import heapq
import math
from collections import Counter
from dataclasses import dataclass
from typing import Literal

import numpy as np

Direction = Literal["to_board", "from_board", "both"]
Kind = Literal["loss", "latency", "corruption", "outage"]


@dataclass(frozen=True)
class FaultSpec:
    kind: Kind
    direction: Direction = "both"
    start_s: float = 0.0
    end_s: float = math.inf
    probability: float = 0.0  # loss: chance that a frame starts a loss burst
    burst_frames: int = 1  # loss: frames lost together
    delay_s: float = 0.0  # latency
    jitter_s: float = 0.0  # latency: uniform in [-jitter, +jitter], never below zero, frames kept in order
    byte_error_rate: float = 0.0  # corruption: chance per byte of one flipped bit

    def applies(self, direction: str, window_s: float) -> bool:
        return self.direction in (direction, "both") and self.start_s <= window_s < self.end_s


class _Direction:
    """One direction's queue of delayed frames and its loss burst state."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.queue: list[tuple[float, int, bytes]] = []  # (due, order, frame)
        self.order = 0
        self.burst_left = 0
        self.last_due = -math.inf


class LinkFaults:
    def __init__(self, specs: list[FaultSpec], rng: np.random.Generator) -> None:
        self.specs = specs
        self.rng = rng
        self.now_s = 0.0
        self.window_s = -math.inf
        self.counts: Counter[str] = Counter()
        self._out = _Direction("to_board")
        self._in = _Direction("from_board")

    def longest_outage_s(self) -> float:
        return max((s.end_s - s.start_s for s in self.specs if s.kind == "outage"), default=0.0)

    def _active(self, direction: str, kind: str) -> list[FaultSpec]:
        return [s for s in self.specs if s.kind == kind and s.applies(direction, self.window_s)]

    def _pass(self, side: _Direction, frame: bytes) -> None:
        """Loss, outage and latency for one frame: dropped, or queued until it is due."""
        if any(s.applies(side.name, self.window_s) for s in self.specs):
            self.counts[f"{side.name}_frames_in_fault_windows"] += 1
        if self._active(side.name, "outage"):
            self.counts[f"{side.name}_outage_dropped"] += 1
            return
        if side.burst_left > 0:
            side.burst_left -= 1
            self.counts[f"{side.name}_lost"] += 1
            return
        for spec in self._active(side.name, "loss"):
            if self.rng.random() < spec.probability:
                side.burst_left = spec.burst_frames - 1
                self.counts[f"{side.name}_lost"] += 1
                return
        delay = 0.0
        for spec in self._active(side.name, "latency"):
            delay += max(spec.delay_s + self.rng.uniform(-spec.jitter_s, spec.jitter_s), 0.0)
        if delay > 0:
            self.counts[f"{side.name}_delayed"] += 1
        side.order += 1
        side.last_due = max(self.now_s + delay, side.last_due)  # a serial line delays, it never reorders
        heapq.heappush(side.queue, (side.last_due, side.order, frame))

    def _due(self, side: _Direction) -> list[bytes]:
        out = []
        while side.queue and side.queue[0][0] <= self.now_s + 1e-12:
            out.append(heapq.heappop(side.queue)[2])
        return out

    def outgoing(self, frame: bytes) -> bytes:
        """Take a frame the bench sends; return the bytes due on the wire now (this frame or earlier ones)."""
        self._pass(self._out, frame)
        return b"".join(self._corrupt(f, "to_board") for f in self._due(self._out))

    def incoming_bytes(self, data: bytes) -> bytes:
        return self._corrupt(data, "from_board") if data else data

    def incoming_frames(self, frames: list[bytes]) -> list[bytes]:
        for frame in frames:
            self._pass(self._in, frame)
        return self._due(self._in)

    def _corrupt(self, data: bytes, direction: str) -> bytes:
        rate = sum(s.byte_error_rate for s in self._active(direction, "corruption"))
        if rate <= 0:
            return data
        hits = np.flatnonzero(self.rng.random(len(data)) < rate)
        if not len(hits):
            return data
        buffer = bytearray(data)
        for index in hits:
            buffer[index] ^= 1 << int(self.rng.integers(8))
        self.counts[f"{direction}_bytes_corrupted"] += len(hits)
        return bytes(buffer)
