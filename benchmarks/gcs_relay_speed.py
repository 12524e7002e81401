"""Real-time factor of `hil run scenarios/hover.yaml` on the emulator with the ground-station relay on
(a GCS listening on loopback receives everything) and with --no-gcs, alternating in one run; medians.

Usage: python benchmarks/gcs_relay_speed.py [--rounds N] [--quick]
"""

from __future__ import annotations

import os
import socket
import statistics
import sys
import tempfile
import threading
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from run_timing import benchmark_parser, realtime_factor, scenario_file


class Gcs(threading.Thread):
    """A plain UDP listener that takes every datagram, as QGroundControl would."""

    def __init__(self) -> None:
        super().__init__(daemon=True)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(0.2)
        self.port = self.sock.getsockname()[1]
        self.datagrams = 0
        self.stop = threading.Event()

    def run(self) -> None:
        while not self.stop.is_set():
            try:
                self.sock.recv(65535)
                self.datagrams += 1
            except TimeoutError:
                pass


def main() -> int:
    parser = benchmark_parser(__doc__)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    rounds = 1 if args.quick else args.rounds
    gcs = Gcs()
    gcs.start()
    relayed, plain = [], []
    with tempfile.TemporaryDirectory() as tmp:
        hover = scenario_file("hover", args.quick, Path(tmp))
        for n in range(rounds):
            relay = ["--no-telemetry", "--gcs", f"udpout:127.0.0.1:{gcs.port}"]
            relayed.append(realtime_factor(hover, relay, Path(tmp) / f"gcs{n}"))
            plain.append(realtime_factor(hover, ["--no-telemetry", "--no-gcs"], Path(tmp) / f"plain{n}"))
            print(f"round {n + 1}: relay on {relayed[-1]:.2f}x, --no-gcs {plain[-1]:.2f}x")
    gcs.stop.set()
    on, off = statistics.median(relayed), statistics.median(plain)
    print(f"\nload average {os.getloadavg()[0]:.2f}; medians of {rounds} rounds; {gcs.datagrams} datagrams "
          "reached the GCS")
    print(f"relay on {on:.2f}x real time, --no-gcs {off:.2f}x: ratio {on / off:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
