"""Waiting that polls (`hil run --spin-wait`): how long it polls, and that a polled read tells "nothing yet" from
"the peer is gone" on every kind of descriptor the links use, on real ptys."""

from __future__ import annotations

import os
import subprocess
import sys
import time

import psutil
import pytest

from firmware_interface.link import open_pty_pair
from firmware_interface.link.errors import LinkLost
from firmware_interface.link.pty import PtyPair
from firmware_interface.link.transports import FdTransport, SerialTransport, SpinWait
from tests.support.cli_runs import ROOT, emulator_pids, wait_flying
from tests.support.recording_digest import simulated_digest


def test_it_polls_twice_the_recent_median_wait_and_not_at_all_for_slow_replies():
    spin = SpinWait(max_s=500e-6)
    assert spin.budget_s() == 500e-6  # no history: one full budget, to learn the first wait
    for _ in range(7):
        spin.waited(100e-6)
    assert spin.budget_s() == 0.0  # too few waits to trust a median: asleep meanwhile
    spin.waited(100e-6)
    assert spin.budget_s() == pytest.approx(200e-6)  # eight waits of 100 µs: poll for 200 µs
    for _ in range(SpinWait.WINDOW):
        spin.waited(300e-6)
    assert spin.budget_s() == 500e-6  # twice 300 µs, held to max_s
    for _ in range(SpinWait.WINDOW):
        spin.waited(2e-3)
    assert spin.budget_s() == 0.0  # replies slower than max_s: sleeping costs little beside them


@pytest.fixture
def pair():
    pair = open_pty_pair()
    yield pair
    pair.master.close()
    pair.release_slave()


def slave_end(pair: PtyPair) -> SerialTransport:
    """The slave end opened as a board's serial port is (pyserial, timeout 0: VMIN 0, a read of nothing is 0 bytes)."""
    return SerialTransport(pair.slave_path)


@pytest.mark.parametrize("end", ["serial port (pty slave)", "pty master"])
def test_a_polled_read_returns_nothing_while_nothing_came_then_the_bytes_then_the_loss(pair, end):
    if end == "pty master":
        reader: FdTransport = pair.master
        write_fd = os.dup(pair.slave_fd)
    else:
        reader = slave_end(pair)
        write_fd = os.dup(pair.master.fd)
    reader.spin = SpinWait()
    started = time.perf_counter()
    assert reader.read(0.02) == b""  # nothing sent: polled, then asleep, and not taken for the peer's end
    assert time.perf_counter() - started >= 0.02
    os.write(write_fd, b"\xfd\x01")
    assert reader.read(1.0) == b"\xfd\x01"
    if end == "pty master":
        pair.release_slave()  # every descriptor of the slave closed: the master reads EIO
    os.close(write_fd)
    if end != "pty master":
        pair.master.close()  # the master closed: the slave is hung up
    with pytest.raises(LinkLost):
        reader.read(1.0)
    if end != "pty master":
        reader.close()


@pytest.mark.usefixtures("fresh_emulators")
@pytest.mark.e2e
def test_a_lockstep_flight_with_both_ends_polling_records_what_it_records_asleep(tmp_path):
    """`hil run --spin-wait` on the emulator: the bench polls for the replies and the emulator it starts (its
    command line says so while it flies) for the frames. In lockstep nothing the run records depends on how
    either end waits: the recording on simulated time is the same, bit for bit, as the flight's without it."""
    scenario = tmp_path / "hold.yaml"
    scenario.write_text("name: hold\nduration_s: 1\nseed: 5\nend: disarm\nreference: {type: hover, altitude_m: 2}\n")
    digests, command_lines = {}, {}
    for label, extra in (("asleep", ()), ("polling", ("--spin-wait",))):
        runs = tmp_path / label
        bench = subprocess.Popen([sys.executable, "-m", "hil", "run", str(scenario), "--runs", str(runs),
                                  "--no-report", "--no-gcs", "--no-telemetry", *extra], cwd=ROOT,
                                 stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        wait_flying(runs, then_s=0.0)
        command_lines[label] = " ".join(psutil.Process(emulator_pids(bench.pid)[0]).cmdline())
        output, _ = bench.communicate(timeout=120)
        assert bench.returncode == 0, output
        digests[label] = simulated_digest(max(runs.iterdir()))
    assert "--spin-wait" in command_lines["polling"] and "--spin-wait" not in command_lines["asleep"]
    assert digests["polling"] == digests["asleep"]
