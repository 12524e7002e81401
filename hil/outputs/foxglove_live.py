"""Live view in Foxglove: the run served over Foxglove's WebSocket protocol (foxglove-sdk), with the
recording's channels and schemas, decimated like the Zenoh telemetry.

The SDK queues each client's messages in its own (Rust) threads and drops the oldest when a client is
slow, so logging from the bench's sink slot never blocks the loop. `hil foxglove` (hil.app.foxglove_bridge) serves
a run seen on Zenoh (another machine's bench) the same way.
"""

from __future__ import annotations

import threading
from typing import Any

import foxglove
import orjson

from firmware_interface.geodesy import LocalFrame
from hil.channels import CHANNEL_MODELS
from hil.loop.frame import StepFrame
from hil.loop.sink import Outcome
from hil.outputs.context import OutputContext, OutputError
from hil.outputs.foxglove_channels import json_channels, view_channels
from hil.outputs.foxglove_messages import FoxgloveViews
from hil.outputs.recorder import frame_messages
from hil.outputs.telemetry import Decimator

DEFAULT_ADDRESS = "127.0.0.1:8765"
SCENE_PERIOD_US = 1_000_000  # the scene goes out again each simulated second for clients that join late
# a live continuous channel at most this often per second of wall time: smooth for a plot or the 3-D view,
# and the view's cost stays the same at 1× (HITL) and at 7× real time (lockstep), where 50 samples per
# simulated second would be 350 a second; the recording keeps every step
MAX_WALL_HZ = 30.0
# the board's streams (50 Hz from the emulator, faster from PX4) under the same cap; its texts, ACKs,
# heartbeats and state changes each matter and always pass
BOARD_STREAM_RATES_HZ = {"board/attitude_target": 50.0, "board/estimates": 50.0, "board/local_position_ned": 50.0,
                         "board/attitude": 50.0}


def parse_address(text: str) -> tuple[str, int]:
    """HOST:PORT (or just PORT, on loopback) -> (host, port); ValueError with the reason."""
    host, _, port = text.rpartition(":")
    if not port.isdigit() or not 0 < int(port) < 65536:
        raise ValueError(f"{text!r}: expected HOST:PORT, e.g. {DEFAULT_ADDRESS}")
    return host or "127.0.0.1", int(port)


class FoxgloveServer:
    """Foxglove WebSocket server with the bench's channels; `publish` takes channel samples."""

    def __init__(self, address: str, local_frame: LocalFrame, start_ns: int, scene: Any = None,
                 rates_hz: dict[str, float] | None = None, decimate: bool = True) -> None:
        host, port = parse_address(address)
        self.context = foxglove.Context()
        self.server = foxglove.start_server(name="hil-bench", host=host, port=port, context=self.context)
        self.port = self.server.port
        self._json = json_channels(self.context, CHANNEL_MODELS)
        self._protobuf = view_channels(self.context)
        self._decimator = Decimator({**BOARD_STREAM_RATES_HZ, **(rates_hz or {})}, MAX_WALL_HZ) if decimate else None
        self._views = FoxgloveViews(local_frame, start_ns)
        self._start_ns = start_ns
        self._scene = scene
        self._next_scene_us = 0
        self._lock = threading.Lock()

    def publish(self, t_us: int, samples: list[tuple[str, dict[str, Any]]]) -> None:
        stamp = self._start_ns + t_us * 1000
        if self._decimator is not None:
            samples = [(c, s) for c, s in samples if self._decimator.passes(c, t_us)]
        with self._lock:
            for channel, sample in samples:
                self._json[channel].log(orjson.dumps(sample, option=orjson.OPT_SERIALIZE_NUMPY), log_time=stamp)
            for topic, message in self._views.messages(samples):
                self._protobuf[topic].log(message.encode(), log_time=stamp)
            if self._scene is not None and t_us >= self._next_scene_us:
                self._next_scene_us = t_us + SCENE_PERIOD_US
                self._protobuf["foxglove/scene"].log(self._scene.encode(), log_time=stamp)

    def on_step(self, frame: StepFrame) -> None:
        self.publish(frame.t_us, frame_messages(frame))

    def on_event(self, t_us: int, text: str) -> None:
        self.publish(t_us, [("events", {"t_us": t_us, "text": text})])

    def close(self, outcome: Outcome) -> None:
        self.stop()

    def stop(self) -> None:
        self.server.stop()


def open_output(context: OutputContext) -> FoxgloveServer | None:
    """The live view when the run was asked for one (`--foxglove`); a taken or invalid address is bad input."""
    if context.foxglove is None:
        return None
    try:
        return FoxgloveServer(context.foxglove, context.local_frame, context.start_ns, context.scene,
                              context.rates_hz)
    except RuntimeError as exc:  # foxglove-sdk's FoxgloveError: the address is taken or invalid
        raise OutputError(f"--foxglove {context.foxglove}: {exc}") from exc
