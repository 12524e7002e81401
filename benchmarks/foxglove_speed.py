"""Real-time factor of `hil run scenarios/gust.yaml` on the emulator serving Foxglove live (a WebSocket
client subscribed to every channel) against the same run without --foxglove, alternating; medians.

Usage: python benchmarks/foxglove_speed.py [--rounds N] [--quick]
"""

from __future__ import annotations

import asyncio
import json
import os
import socket
import statistics
import sys
import tempfile
import threading
from pathlib import Path

import websockets
from websockets.typing import Subprotocol

sys.path.insert(0, str(Path(__file__).resolve().parent))
from run_timing import benchmark_parser, realtime_factor, scenario_file

SUBPROTOCOLS = [Subprotocol("foxglove.websocket.v1"), Subprotocol("foxglove.sdk.v1")]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Viewer(threading.Thread):
    """A Foxglove client that subscribes to every advertised channel and counts what arrives."""

    def __init__(self, port: int) -> None:
        super().__init__(daemon=True)
        self.url = f"ws://127.0.0.1:{port}"
        self.messages = 0
        self.done = threading.Event()

    def run(self) -> None:
        asyncio.run(self._view())

    async def _view(self) -> None:
        while not self.done.is_set():
            try:
                async with websockets.connect(self.url, subprotocols=SUBPROTOCOLS, max_size=None) as ws:
                    await self._consume(ws)
            except (OSError, websockets.ConnectionClosed):
                await asyncio.sleep(0.05)

    async def _consume(self, ws: websockets.ClientConnection) -> None:
        async for frame in ws:
            if isinstance(frame, str):
                message = json.loads(frame)
                if message["op"] == "advertise":
                    await ws.send(json.dumps({"op": "subscribe", "subscriptions": [
                        {"id": c["id"], "channelId": c["id"]} for c in message["channels"]]}))
            else:
                self.messages += 1


def main() -> int:
    parser = benchmark_parser(__doc__)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    rounds = 1 if args.quick else args.rounds
    live, plain, received = [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        gust = scenario_file("gust", args.quick, Path(tmp))
        for n in range(rounds):
            port = free_port()
            viewer = Viewer(port)
            viewer.start()
            live.append(realtime_factor(gust, ["--no-gcs", "--foxglove", f"127.0.0.1:{port}"], Path(tmp) / f"live{n}"))
            viewer.done.set()
            received.append(viewer.messages)
            plain.append(realtime_factor(gust, ["--no-gcs"], Path(tmp) / f"plain{n}"))
            print(f"round {n + 1}: --foxglove {live[-1]:.2f}x ({viewer.messages} messages to the client), "
                  f"without {plain[-1]:.2f}x")
    on, off = statistics.median(live), statistics.median(plain)
    print(f"\nload average {os.getloadavg()[0]:.2f}; medians of {rounds} rounds")
    print(f"--foxglove with a client on every channel {on:.2f}x real time, without {off:.2f}x: ratio {on / off:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
