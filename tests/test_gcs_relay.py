"""The ground-station relay: a GCS (pymavlink, on QGroundControl's port) sees the board during a run."""

from __future__ import annotations

import json
import subprocess
import sys
import threading
import time
from collections import Counter
from pathlib import Path

from pymavlink import mavutil

ROOT = Path(__file__).resolve().parent.parent


class Listener(threading.Thread):
    """A GCS on udpin:127.0.0.1:PORT counting what reaches it."""

    def __init__(self, port: int) -> None:
        super().__init__(daemon=True)
        self.link = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}")
        self.counts: Counter[str] = Counter()
        self.stop = threading.Event()

    def run(self) -> None:
        while not self.stop.is_set():
            msg = self.link.recv_match(blocking=True, timeout=0.2)
            if msg is not None:
                self.counts[msg.get_type()] += 1


def test_a_gcs_receives_the_emulators_traffic_but_no_hil_frames(tmp_path):
    listener = Listener(14561)
    listener.start()
    scenario = tmp_path / "s.yaml"
    scenario.write_text("name: s\nduration_s: 3\nseed: 4\nreference: {type: hover, altitude_m: 2}\n")
    run = subprocess.run([sys.executable, "-m", "hil.cli", "run", str(scenario), "--runs", str(tmp_path / "runs"),
                          "--no-telemetry", "--gcs", "udpout:127.0.0.1:14561"], capture_output=True, text=True,
                         timeout=300, cwd=ROOT)
    time.sleep(0.5)
    listener.stop.set()
    listener.join(5)
    assert run.returncode == 0, run.stdout + run.stderr
    metrics = json.loads(next((tmp_path / "runs").iterdir()).joinpath("metrics.json").read_text())
    sim_s = metrics["timing"]["sim_s"]
    # the emulator beats at 1 Hz of its (simulated) time; every beat reaches the GCS
    assert abs(listener.counts["HEARTBEAT"] - sim_s) <= 2
    assert listener.counts["ATTITUDE"] > 0 and listener.counts["COMMAND_ACK"] > 0
    assert not any(kind.startswith("HIL_") for kind in listener.counts)
    assert metrics["gcs"]["frames_to_gcs"] == sum(listener.counts.values())


def test_no_gcs_turns_the_relay_off_and_a_bad_endpoint_is_bad_input(tmp_path):
    bad = subprocess.run([sys.executable, "-m", "hil.cli", "run", "scenarios/hover.yaml", "--gcs", "udpout:nowhere",
                          "--runs", str(tmp_path)], capture_output=True, text=True, timeout=60, cwd=ROOT)
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1 and "--gcs udpout:nowhere" in bad.stderr
    scenario = tmp_path / "s.yaml"
    scenario.write_text("name: s\nduration_s: 1\nseed: 4\nreference: {type: hover, altitude_m: 2}\nend: disarm\n")
    run = subprocess.run([sys.executable, "-m", "hil.cli", "run", str(scenario), "--runs", str(tmp_path / "runs"),
                          "--no-telemetry", "--no-gcs"], capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert run.returncode == 0, run.stdout + run.stderr
    metrics = json.loads(next((tmp_path / "runs").iterdir()).joinpath("metrics.json").read_text())
    board_line = next(line for line in run.stdout.splitlines() if line.startswith("board:"))
    assert "gcs" not in metrics and "relay" not in board_line
