"""The link as PX4 users type it: mavutil's connection strings, --baud, messages that fit the case,
`hil ports`, and `hil emulate` from the command line, on real ptys."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from firmware_interface.link import Link, LinkError, open_pty_pair, parse_connection
from firmware_interface.link.ports import pixhawk_maker
from tests.support.summary_text import summary_field

pytestmark = pytest.mark.e2e  # drives the bench's processes (hil, the emulator) end to end

ROOT = Path(__file__).resolve().parent.parent


def test_baud_applies_where_the_string_names_none():
    assert parse_connection("/dev/ttyUSB0", baud=57600).number == 57600
    assert parse_connection("/dev/ttyUSB0,115200", baud=57600).number == 115200


@pytest.mark.parametrize("text", ["udp:14550", "com3", "/dev/ttyACM0,fast", "tcp:host:99999"])
def test_a_malformed_string_is_bad_input(text, tmp_path):
    with pytest.raises(LinkError):
        parse_connection(text)
    run = subprocess.run([sys.executable, "-m", "hil", "run", "--no-report", "scenarios/hover.yaml", "--port", text,
                          "--runs", str(tmp_path)], capture_output=True, text=True, timeout=60, cwd=ROOT)
    assert run.returncode == 2 and run.stderr.count("\n") == 1 and "--port" in run.stderr


def run_on_serial(port: str, tmp_path: Path) -> str:
    run = subprocess.run([sys.executable, "-m", "hil", "run", "--no-report", "scenarios/hover.yaml", "--port", port,
                          "--connect-timeout", "1", "--no-telemetry", "--no-gcs", "--runs", str(tmp_path)],
                         capture_output=True, text=True, timeout=60, cwd=ROOT)
    assert run.returncode == 3
    return summary_field(run.stdout, "ended")


def test_a_missing_device_says_it_is_missing(tmp_path):
    ended = run_on_serial("/dev/ttyACM97", tmp_path)
    assert "no device /dev/ttyACM97" in ended and "QGroundControl" not in ended


def test_a_silent_port_and_a_port_with_garbage_say_what_arrived(tmp_path):
    pair = open_pty_pair()
    assert "no bytes arrived at all" in run_on_serial(pair.slave_path, tmp_path / "silent")
    stop = threading.Event()

    def babble() -> None:  # what a board at another baud rate looks like: bytes, never a frame
        while not stop.is_set():
            with contextlib.suppress(OSError):
                os.write(pair.master.fd, bytes(range(0, 250, 7)))
            time.sleep(0.01)

    thread = threading.Thread(target=babble, daemon=True)
    thread.start()
    try:
        ended = run_on_serial(pair.slave_path, tmp_path / "garbage")
    finally:
        stop.set()
        thread.join()
        pair.master.close()
        pair.release_slave()
    assert "bytes arrived but no MAVLink frame: a wrong baud rate?" in ended


def test_pixhawk_identification_by_usb_vendor_or_product():
    assert pixhawk_maker(0x26AC, "PX4 FMU v5.x") == "PX4 FMU"
    assert pixhawk_maker(0x2DAE, "CubeOrange") == "CubePilot"
    assert pixhawk_maker(0x0403, "FT232R USB UART") is None  # an FTDI adapter
    assert pixhawk_maker(None, "Pixhawk6X") == "PX4"


def test_hil_ports_says_when_no_pixhawk_is_there():
    out = subprocess.run([sys.executable, "-m", "hil", "ports"], capture_output=True, text=True, timeout=30,
                         cwd=ROOT).stdout
    assert "no Pixhawk found" in out  # this machine has no USB flight controller


def test_hil_emulate_runs_from_the_command_line_and_speaks_px4s_heartbeat():
    assert "--port" in subprocess.run([sys.executable, "-m", "hil", "emulate", "--help"], capture_output=True,
                                      text=True, timeout=30, cwd=ROOT).stdout
    pair = open_pty_pair()
    emulator = subprocess.Popen([sys.executable, "-m", "hil", "emulate", "--port", pair.slave_path],
                                stderr=subprocess.PIPE, text=True, cwd=ROOT)
    link = Link(pair.master)
    try:
        deadline, heartbeat = time.monotonic() + 15, None
        while heartbeat is None and time.monotonic() < deadline:
            heartbeat = next((m for m in link.receive(0.2) if m.get_type() == "HEARTBEAT"), None)
        assert heartbeat is not None and heartbeat.autopilot == 12  # MAV_AUTOPILOT_PX4
    finally:
        emulator.send_signal(signal.SIGTERM)
        assert emulator.wait(10) == 0, emulator.stderr.read()
        link.close()
        pair.release_slave()
