"""MAVSDK, a real GCS client, reads the emulator's telemetry through the bench's ground-station relay."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from tests.support.mavsdk_client import read_telemetry

pytestmark = pytest.mark.e2e  # drives the bench's processes (hil, the emulator) end to end

ROOT = Path(__file__).resolve().parent.parent


def test_mavsdk_reads_position_attitude_armed_and_mode_through_the_relay(tmp_path):
    bench = subprocess.Popen([sys.executable, "-m", "hil", "run", "--no-report", "scenarios/hover.yaml",
                              "--runs", str(tmp_path), "--no-telemetry", "--gcs", "udpout:127.0.0.1:14591"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        seen = read_telemetry(14591, 60)
    finally:
        out, err = bench.communicate(timeout=300)
    assert bench.returncode == 0, out + err
    position, attitude = seen["position"], seen["attitude"]
    assert abs(position.latitude_deg - 47.397742) < 1e-3 and abs(position.longitude_deg - 8.545594) < 1e-3
    assert abs(attitude.roll_deg) < 20 and abs(attitude.pitch_deg) < 20
    assert seen["armed"] is True and seen["flight_mode"] in ("OFFBOARD", "POSCTL", "LAND")
