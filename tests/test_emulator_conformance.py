"""The emulator as a board: a separate process on a real pty, driven by the bench's board session."""

from __future__ import annotations

import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from firmware_interface import hil_codec as codec
from firmware_interface.board import SIMULATED, BoardError, BoardSession
from firmware_interface.board_waits import arm
from firmware_interface.emulator import EmulatedBoard, build_config
from firmware_interface.link import Link, open_pty_pair
from firmware_interface.link.transports import SerialTransport
from hil.boards.registry import board_target
from hil.boards.target import LinkSettings
from hil.scenario.loader import load_scenario
from hil.sensors import Home, SensorsConfig, SensorSuite, TrueState

pytestmark = pytest.mark.e2e  # drives the bench's processes (hil, the emulator) end to end

G = 9.80665
ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture
def emulator():
    pair = open_pty_pair()
    proc = subprocess.Popen([sys.executable, "-m", "firmware_interface.emulator", "--port", pair.slave_path],
                            stderr=subprocess.PIPE, text=True)
    session = BoardSession(Link(pair.master), SIMULATED, watchdog_s=2.0)
    info = session.wait_heartbeat(10.0)
    pair.release_slave()
    yield session, info, proc
    proc.terminate()
    proc.wait(5)
    session.link.close()


class RestingVehicle:
    """Sensor packets of a vehicle resting at home, through the bench's own sensor models."""

    def __init__(self) -> None:
        self.suite = SensorSuite(SensorsConfig(), Home(), 250.0, np.random.default_rng(0))
        self.k = 0

    def step(self, session: BoardSession) -> codec.ActuatorOutputs | None:
        truth = TrueState(4000 * (self.k + 1), np.zeros(3), np.zeros(3), np.array([1.0, 0, 0, 0]), np.zeros(3),
                          np.array([0.0, 0.0, -G]))
        self.k += 1
        readings, gps = self.suite.step(truth)
        return session.exchange(readings, gps)


def test_heartbeat_arming_lockstep_and_failsafe(emulator):
    session, info, _proc = emulator
    assert (info.autopilot, info.vehicle_type, info.hil_enabled, info.armed) == (12, 2, True, False)

    vehicle = RestingVehicle()
    outputs = [vehicle.step(session) for _ in range(50)]
    assert session.lockstep  # lockstep from the first reply on, like PX4 SITL
    assert all(o is not None and o.motors == (0.0, 0.0, 0.0, 0.0) and not o.armed for o in outputs[5:])

    with pytest.raises(BoardError, match=r"arming refused \(MAV_RESULT 2\): Arming denied: estimator not settled"):
        arm(session, True, timeout_s=2.0, pump=lambda: vehicle.step(session))
    for _ in range(int(2.5 * 250)):  # the estimator settles on 2 s of good data
        vehicle.step(session)
    arm(session, True, timeout_s=2.0, pump=lambda: vehicle.step(session))

    counts_before = session.link.counters["frames_in"]
    sent = 200
    replies = []
    for _ in range(sent):
        replies.append(vehicle.step(session))
    assert all(r.lockstep and r.flags == 1 and r.armed for r in replies)
    assert len({r.t_us for r in replies}) == sent  # one distinct reply per HIL_SENSOR, echoing its time
    assert [r.t_us for r in replies] == [4000 * (vehicle.k - sent + i + 1) for i in range(sent)]
    assert session.link.counters["frames_in"] - counts_before >= sent

    time.sleep(0.8)  # no HIL_SENSOR for > 0.5 s while armed
    deadline = time.monotonic() + 3.0
    while time.monotonic() < deadline and not any("Failsafe" in t for _, t in session.report.status_texts):
        session.poll(0.1)
    assert any("Failsafe: no HIL_SENSOR" in t for _, t in session.report.status_texts)
    out = vehicle.step(session)
    assert out is not None and not out.armed and out.motors == (0.0, 0.0, 0.0, 0.0)


def test_heartbeat_with_hil_enabled_within_one_second_then_at_1_hz():
    pair = open_pty_pair()
    board = EmulatedBoard(Link(SerialTransport(pair.slave_path)), build_config())
    pair.release_slave()
    stop = threading.Event()
    thread = threading.Thread(target=board.run, args=(stop.is_set,), daemon=True)
    bench = Link(pair.master)
    started = time.monotonic()
    thread.start()
    beats: list[float] = []
    while time.monotonic() - started < 3.05:
        beats += [time.monotonic() - started for m in bench.receive(0.05) if m.get_type() == "HEARTBEAT"]
    stop.set()
    thread.join(2.0)
    bench.close()
    assert beats and beats[0] < 1.0
    assert len(beats) in (3, 4)  # t = 0, 1, 2 (and 3) s


def test_the_emulator_the_bench_starts_sends_nothing_on_the_wall_clock_before_its_first_sensor_frame(tmp_path):
    """Its heartbeats before the first HIL_SENSOR came each wall-clock second; under load one came after the bench's
    pre-step drain and was recorded in step 1, changing the recording's digest. Attached by the bench (which holds
    the pty from before the emulator starts, and talks on it meanwhile), it sends the one the attach waits for, then
    heartbeats only on the simulation clock: step 1 holds exactly one."""
    handle = board_target("emulator").attach(load_scenario(ROOT / "scenarios" / "hover.yaml"), tmp_path,
                                             LinkSettings())
    try:
        session = handle.hil_session
        session.take_inbox()  # the heartbeat the attach waited for
        quiet_until = time.monotonic() + 2.2  # a heartbeat a wall-clock second would have come twice
        while time.monotonic() < quiet_until:
            session.service()  # the bench's own heartbeat each second: the emulator hears the bench
            session.poll(0.05)
        assert [m.get_type() for m in session.take_inbox()] == []
        reply = RestingVehicle().step(session)
        assert reply is not None and reply.t_us == 4000
        assert [m.get_type() for m in session.take_inbox()].count("HEARTBEAT") == 1  # the simulation clock's first
    finally:
        handle.close()


def test_emulator_exits_when_the_bench_closes_the_pty(emulator):
    session, _, proc = emulator
    session.link.close()
    assert proc.wait(5) == 0
    assert "link lost" in proc.stderr.read()
