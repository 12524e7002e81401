"""`link.tlog`: the whole board link of a run in QGroundControl's tlog format, read back with pymavlink's
own readers (mavutil and mavlogdump.py), both directions, every HIL frame, in order."""

from __future__ import annotations

import json
import subprocess
import sys
from collections import Counter
from itertools import pairwise
from pathlib import Path

import pytest
from pymavlink import mavutil

pytestmark = pytest.mark.e2e  # drives the bench's processes (hil, the emulator) end to end

ROOT = Path(__file__).resolve().parent.parent


def test_the_tlog_holds_every_hil_frame_of_the_run_in_order(tmp_path):
    scenario = tmp_path / "short.yaml"
    scenario.write_text("name: short\nduration_s: 1\nseed: 4\nreference: {type: hover, altitude_m: 2}\nend: disarm\n")
    run = subprocess.run([sys.executable, "-m", "hil", "run", "--no-report", str(scenario),
                          "--runs", str(tmp_path / "runs"), "--no-telemetry"],
                         capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert run.returncode == 0, run.stdout + run.stderr
    run_dir = next((tmp_path / "runs").iterdir())
    metrics = json.loads((run_dir / "metrics.json").read_text())
    steps = round(metrics["timing"]["sim_s"] * 250)
    log = mavutil.mavlink_connection(str(run_dir / "link.tlog"))
    counts: Counter[str] = Counter()
    stamps, sensor_times, reply_times = [], [], []
    while (msg := log.recv_match()) is not None:
        counts[msg.get_type()] += 1
        stamps.append(msg._timestamp)
        if msg.get_type() == "HIL_SENSOR":
            sensor_times.append(msg.time_usec)
        elif msg.get_type() == "HIL_ACTUATOR_CONTROLS":
            reply_times.append(msg.time_usec)
    assert counts["HIL_SENSOR"] == steps and counts["HIL_ACTUATOR_CONTROLS"] == steps
    assert sensor_times == sorted(set(sensor_times))  # in order, none twice
    assert reply_times == sensor_times  # the emulator answers every step, echoing its time
    assert all(b > a for a, b in pairwise(stamps))
    assert counts["HEARTBEAT"] > 0 and counts["COMMAND_LONG"] > 0 and counts["COMMAND_ACK"] > 0  # both directions
    dump = subprocess.run([sys.executable, str(Path(sys.executable).parent / "mavlogdump.py"), "--types", "HIL_SENSOR",
                           str(run_dir / "link.tlog")], capture_output=True, text=True, timeout=120)
    assert dump.returncode == 0 and dump.stdout.count("HIL_SENSOR {") == steps
