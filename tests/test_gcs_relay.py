"""The ground-station relay: a GCS (pymavlink, on QGroundControl's port) sees the board during a run."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
import threading
import time
from collections import Counter
from pathlib import Path

import pytest
from pymavlink import mavutil

from hil.boards.gcs_relay import DATAGRAM_BYTES, RELAY_PERIOD_S, GcsBridge, datagrams

pytestmark = pytest.mark.e2e  # drives the bench's processes (hil, the emulator) end to end

ROOT = Path(__file__).resolve().parent.parent


class Listener(threading.Thread):
    """A GCS on udpin:127.0.0.1:PORT counting what reaches it."""

    def __init__(self, port: int) -> None:
        super().__init__(daemon=True)
        self.link = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}")
        self.link.port.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 22)  # a lockstep run is fast
        self.counts: Counter[str] = Counter()
        self.stop = threading.Event()

    def run(self) -> None:
        while not self.stop.is_set():
            msg = self.link.recv_match(blocking=True, timeout=0.2)
            if msg is not None:
                self.counts[msg.get_type()] += 1


def test_the_relays_frames_go_whole_and_in_order_in_datagrams_that_fit_an_ethernet_mtu():
    frames = [bytes([k]) * n for k, n in enumerate([280, 280, 280, 280, 280, 100, 1472, 12, 300])]
    packed = datagrams(frames)
    assert b"".join(packed) == b"".join(frames)
    # by hand: five 280-byte frames fill 1400 bytes, the 100-byte one would make 1500 > 1472 (1500 less IP's 20
    # and UDP's 8); then 100 alone (1472 more would not fit), 1472 alone, and 12 + 300
    assert DATAGRAM_BYTES == 1500 - 20 - 8
    assert [len(d) for d in packed] == [1400, 100, 1472, 312]
    assert datagrams([]) == []


def test_a_relay_pass_is_due_once_per_period_of_the_wall_clock():
    times = iter([0.0, 0.4e-3, 1.0e-3, 1.5e-3, 2.2e-3, 10e-3])
    bridge = GcsBridge([], clock=lambda: next(times))
    assert RELAY_PERIOD_S == 1e-3
    assert [bridge.due() for _ in range(6)] == [True, False, True, False, True, True]


def test_a_gcs_receives_the_emulators_traffic_but_no_hil_frames(tmp_path):
    listener = Listener(14561)
    listener.start()
    scenario = tmp_path / "s.yaml"
    scenario.write_text("name: s\nduration_s: 3\nseed: 4\nreference: {type: hover, altitude_m: 2}\n")
    run = subprocess.run([sys.executable, "-m", "hil", "run", "--no-report", str(scenario),
                          "--runs", str(tmp_path / "runs"), "--no-telemetry", "--gcs", "udpout:127.0.0.1:14561"],
                         capture_output=True, text=True, timeout=300, cwd=ROOT)
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
    # UDP: a reader thread on a loaded machine may miss a few datagrams, but nothing may come that was not sent
    received, relayed = sum(listener.counts.values()), metrics["gcs"]["frames_to_gcs"]
    assert 0.98 * relayed <= received <= relayed


def test_no_gcs_turns_the_relay_off_and_a_bad_endpoint_is_bad_input(tmp_path):
    bad = subprocess.run([sys.executable, "-m", "hil", "run", "--no-report", "scenarios/hover.yaml",
                          "--gcs", "udpout:nowhere", "--runs", str(tmp_path)],
                         capture_output=True, text=True, timeout=60, cwd=ROOT)
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1 and "--gcs udpout:nowhere" in bad.stderr
    scenario = tmp_path / "s.yaml"
    scenario.write_text("name: s\nduration_s: 1\nseed: 4\nreference: {type: hover, altitude_m: 2}\nend: disarm\n")
    run = subprocess.run([sys.executable, "-m", "hil", "run", "--no-report", str(scenario),
                          "--runs", str(tmp_path / "runs"), "--no-telemetry", "--no-gcs"],
                         capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert run.returncode == 0, run.stdout + run.stderr
    metrics = json.loads(next((tmp_path / "runs").iterdir()).joinpath("metrics.json").read_text())
    board_line = next(line for line in run.stdout.splitlines() if line.startswith("board:"))
    assert "gcs" not in metrics and "relay" not in board_line


class ParameterGcs(threading.Thread):
    """A pymavlink GCS: on the board's first heartbeat it lists the parameters, then sets one."""

    def __init__(self, port: int, name: str, value: float) -> None:
        super().__init__(daemon=True)
        self.link = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255, source_component=190)
        self.name, self.value = name, value
        self.params: dict[str, float] = {}
        self.echo: float | None = None
        self.extra: dict[str, object] = {}

    def run(self) -> None:
        link = self.link
        if link.recv_match(type="HEARTBEAT", blocking=True, timeout=60) is None:
            return
        link.mav.heartbeat_send(6, 8, 0, 0, 0)
        link.mav.param_request_list_send(1, 1)
        while (msg := link.recv_match(type="PARAM_VALUE", blocking=True, timeout=5)) is not None:
            self.params[msg.param_id] = msg.param_value
            if len(self.params) == msg.param_count:
                break
        link.mav.param_set_send(1, 1, self.name.encode(), self.value, mavutil.mavlink.MAV_PARAM_TYPE_REAL32)
        msg = link.recv_match(type="PARAM_VALUE", blocking=True, timeout=5)
        self.echo = msg.param_value if msg is not None and msg.param_id == self.name else None
        link.mav.mission_request_list_send(1, 1)
        self.extra["mission"] = link.recv_match(type="MISSION_COUNT", blocking=True, timeout=5)
        link.mav.command_long_send(1, 1, mavutil.mavlink.MAV_CMD_REQUEST_MESSAGE, 0, 148, 0, 0, 0, 0, 0, 0)
        self.extra["version"] = link.recv_match(type="AUTOPILOT_VERSION", blocking=True, timeout=5)


def test_a_gcs_reads_the_emulators_parameters_and_a_gain_it_sets_takes_effect(tmp_path):
    """The GCS lowers SMARC's projection bound on m̂ to 1.05 kg before a 0.5 kg payload arrives: m̂ must then
    run into the new bound and stay at it, while the true mass is 1.5 kg (it would follow it otherwise)."""
    gcs = ParameterGcs(14562, "SMARC_MASS_MAX", 1.05)
    gcs.start()
    scenario = tmp_path / "payload.yaml"
    scenario.write_text("name: payload\nduration_s: 12\nseed: 3\nreference: {type: hover, altitude_m: 3}\n"
                        "payload: [{t_s: 5, mass_kg: 0.5}]\n")
    run = subprocess.run([sys.executable, "-m", "hil", "run", "--no-report", str(scenario),
                          "--runs", str(tmp_path / "runs"), "--no-telemetry", "--gcs", "udpout:127.0.0.1:14562"],
                         capture_output=True, text=True, timeout=300, cwd=ROOT)
    gcs.join(10)
    assert run.returncode == 0, run.stdout + run.stderr
    assert {"SMARC_C1", "SMARC_GAMMA2", "SMARC_MASS_MAX", "SYS_HITL", "EKF2_GPS_DELAY",
            "MPC_LAND_SPEED"} <= set(gcs.params)
    assert gcs.params["SMARC_MASS_MAX"] == 2.5 and gcs.params["EKF2_GPS_DELAY"] == 120.0
    assert gcs.echo is not None and abs(gcs.echo - 1.05) < 1e-6
    assert gcs.extra["mission"].count == 0 and gcs.extra["version"] is not None
    from mcap.reader import make_reader

    set_at, m_hat = None, []
    with open(next((tmp_path / "runs").iterdir()) / "recording.mcap", "rb") as f:
        for _, channel, message in make_reader(f).iter_messages(topics=["hil/events", "hil/board/estimates"]):
            sample = json.loads(message.data)
            if channel.topic == "hil/events" and "SMARC_MASS_MAX set to 1.05" in sample["text"]:
                set_at = sample["t_us"]
            elif channel.topic == "hil/board/estimates" and set_at is not None and sample["t_us"] > set_at:
                m_hat.append(sample["values"]["m_hat"])
    assert set_at is not None and m_hat
    assert max(m_hat) <= 1.05 + 1e-6 and m_hat[-1] >= 1.04
