"""Zenoh telemetry on loopback (multicast scouting off): rates, ordering, meta, hil watch, clean exits."""

from __future__ import annotations

import json
import os
import pty
import select
import signal
import subprocess
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest

from firmware_interface.hil_codec import SensorReadings
from hil.loop.frame import StepFrame
from hil.loop.sink import Outcome
from hil.outputs.telemetry import DEFAULT_RATES_HZ, TelemetryPublisher, fetch_meta
from hil.outputs.zenoh_session import ZenohOptions, open_session
from hil.scenario.environment import EnvironmentSample
from plant_fmu import Plant
from tests.support.cli_runs import wait_flying
from tests.support.ports import free_port, wait_listening

pytestmark = pytest.mark.e2e  # drives the bench's processes (hil, the emulator) end to end

ROOT = Path(__file__).resolve().parent.parent


def endpoint_port(endpoint: str) -> int:
    return int(endpoint.rsplit(":", 1)[1])


def scenario_file(tmp_path: Path, duration: float = 4.0, altitude: float = 3.0) -> Path:
    path = tmp_path / "t.yaml"
    path.write_text(f"name: tele\nduration_s: {duration}\nseed: 2\nreference: {{type: hover, altitude_m: {altitude}}}\n"
                    "end: disarm\ntelemetry: {rates_hz: {state: 100, sensors/imu: 25}}\n")
    return path


def bench(scenario: Path, runs: Path, endpoint: str, connect: bool = False) -> subprocess.Popen[str]:
    return subprocess.Popen([sys.executable, "-m", "hil", "run", "--no-report", str(scenario), "--runs", str(runs),
                             "--zenoh-connect" if connect else "--zenoh-listen", endpoint],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)


def test_a_subscriber_in_another_process_gets_every_channel_at_its_rate(tmp_path):
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    lines_path = tmp_path / "echo.jsonl"
    with open(lines_path, "wb") as sink:  # a file, not a pipe: a full pipe would block the subscriber
        echo = subprocess.Popen([sys.executable, "-m", "hil", "echo", "hil/**", "--zenoh-listen", endpoint],
                                stdout=sink, stderr=subprocess.DEVNULL, cwd=ROOT)
        wait_listening(endpoint_port(endpoint))  # the bench connects to it when it opens its session
        # ~15 s simulated with arming and take-off: 75 GPS fixes, the slowest channel, at 5 a second
        run = bench(scenario_file(tmp_path, duration=6.0), tmp_path / "runs", endpoint, connect=True)
        assert run.wait(300) == 0, run.stderr.read()
        time.sleep(1.0)
        echo.send_signal(signal.SIGINT)
        assert echo.wait(10) == 0
    samples: dict[str, list[int]] = defaultdict(list)
    for line in lines_path.read_text().splitlines():
        record = json.loads(line)
        samples[record["key"].split("/", 2)[2]].append(record["sample"]["t_us"])
    assert set(samples) >= {"state", "reference", "sensors/imu", "sensors/gps", "sensors/baro", "sensors/mag",
                            "actuators", "environment", "board/heartbeat", "board/attitude_target", "board/link",
                            "timing", "events", "summary"}
    for channel, stamps in samples.items():
        assert stamps == sorted(stamps), f"{channel}: t_us not monotonic"
    # the subscriber connects a moment after the bench starts publishing: measure over what it saw
    rates = {"state": 100.0, "sensors/imu": 25.0, "actuators": DEFAULT_RATES_HZ["actuators"],
             "environment": DEFAULT_RATES_HZ["environment"], "timing": DEFAULT_RATES_HZ["timing"],
             "sensors/baro": DEFAULT_RATES_HZ["sensors/baro"], "sensors/mag": DEFAULT_RATES_HZ["sensors/mag"],
             "sensors/gps": 5.0}  # px4_sitl GPS delivers 5 fixes/s, under the 10 Hz channel rate
    for channel, hz in rates.items():
        stamps = samples[channel]
        span_s = (stamps[-1] - stamps[0]) / 1e6
        assert (len(stamps) - 1) / span_s == pytest.approx(hz, rel=0.10), channel


def test_meta_queryable_answers_late_joiners(tmp_path):
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    run = bench(scenario_file(tmp_path, duration=60.0), tmp_path / "runs", endpoint)
    session = open_session(ZenohOptions(connect=[endpoint], multicast_scouting=False))
    try:
        deadline = time.monotonic() + 60
        run_ids: list[str] = []
        token = session.liveliness().declare_subscriber("hil/*", lambda s: run_ids.append(str(s.key_expr)[4:]),
                                                         history=True)
        while not run_ids and time.monotonic() < deadline:
            time.sleep(0.2)
        meta = fetch_meta(session, run_ids[0])
        token.undeclare()
        assert meta is not None and meta["run_id"] == run_ids[0] and meta["scenario"]["name"] == "tele"
        assert meta["scenario"]["duration_s"] == 60.0 and meta["seed"] == 2
    finally:
        session.close()
        run.send_signal(signal.SIGINT)
        run.wait(30)


def read_screen(fd: int, seconds: float) -> bytes:
    out = b""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        ready, _, _ = select.select([fd], [], [], 0.1)
        if ready:
            try:
                out += os.read(fd, 65536)
            except OSError:
                break
    return out


def watch_on_a_terminal(endpoint: str, listen: bool = False) -> tuple[subprocess.Popen[bytes], int]:
    """`hil watch --latest` with a real pseudo-terminal as its screen; listening, or connecting to the bench."""
    master, slave = pty.openpty()
    proc = subprocess.Popen([sys.executable, "-m", "hil", "watch", "--latest",
                             "--zenoh-listen" if listen else "--zenoh-connect", endpoint],
                            stdin=slave, stdout=slave, stderr=slave, cwd=ROOT,
                            env={**os.environ, "COLUMNS": "120", "LINES": "40", "TERM": "xterm"})
    os.close(slave)
    if listen:
        wait_listening(endpoint_port(endpoint))  # listening before the bench starts
    return proc, master


@pytest.mark.parametrize("watch_first", [True, False], ids=["watch-before-run", "watch-after-start"])
def test_hil_watch_shows_the_run_on_a_terminal_and_exits_with_it(tmp_path, watch_first):
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    if watch_first:
        # the watcher must be reachable before the bench exists: it listens, the bench connects
        proc, master = watch_on_a_terminal(endpoint, listen=True)
        run = bench(scenario_file(tmp_path, 30.0), tmp_path / "runs", endpoint, connect=True)
    else:
        run = bench(scenario_file(tmp_path, 30.0), tmp_path / "runs", endpoint)
        wait_flying(tmp_path / "runs")  # the run lasts ~8 s of wall time
        proc, master = watch_on_a_terminal(endpoint)
    screen = b""
    ended = None
    while proc.poll() is None:  # keep reading the terminal, as a terminal does
        screen += read_screen(master, 0.1)
        if ended is None and run.poll() is not None:
            ended = time.monotonic()
        assert ended is None or time.monotonic() - ended < 2.0, "the watcher must leave with the run"
    screen += read_screen(master, 0.3)
    text = screen.decode(errors="replace")
    assert run.wait(5) == 0 and proc.returncode == 0
    assert "hil run" in text and "position (m)" in text and "reference (m)" in text and "real-time factor" in text
    assert "phase" in text and "mission" in text and "result: PASS" in text
    os.close(master)


def test_bench_and_watch_exit_within_2s_of_run_end_or_ctrl_c_20_times(tmp_path):
    for i in range(20):
        endpoint = f"tcp/127.0.0.1:{free_port()}"
        ctrl_c = i % 2 == 1
        # the watcher first: `watch --latest` follows the next run to start, and a 0.5 s run can be over
        # before a watcher started after it has joined
        watcher = subprocess.Popen([sys.executable, "-m", "hil", "watch", "--latest", "--zenoh-listen", endpoint],
                                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=ROOT)
        wait_listening(endpoint_port(endpoint))
        run = bench(scenario_file(tmp_path, duration=60.0 if ctrl_c else 0.5, altitude=1.0), tmp_path / f"r{i}",
                    endpoint, connect=True)
        if ctrl_c:
            wait_flying(tmp_path / f"r{i}", then_s=0.2)  # mid-run: what ends is a run in progress
            run.send_signal(signal.SIGINT)
            watcher.send_signal(signal.SIGINT)
            stopped = time.monotonic()
            # the watcher ends by its own Ctrl-C (130) or, if the bench's summary beat it, by the run's end (0)
            assert run.wait(10) == 130 and watcher.wait(10) in (0, 130)
        else:
            assert run.wait(120) == 0
            stopped = time.monotonic()
            watcher.wait(10)
        assert time.monotonic() - stopped < 2.0, f"iteration {i}"


@pytest.mark.slow
def test_a_stopped_subscriber_does_not_hold_up_the_end_of_a_run(tmp_path):
    """A subscriber frozen with SIGSTOP (a hung viewer): each of 10 benches exits within 2 s of writing its
    summary (the summary put and the session close are bounded)."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    scenario = tmp_path / "s.yaml"
    scenario.write_text("name: stall\nduration_s: 2\nreference: {type: hover, altitude_m: 2}\nend: disarm\n")
    echo = subprocess.Popen([sys.executable, "-m", "hil", "echo", "hil/**", "--zenoh-listen", endpoint],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=ROOT)
    wait_listening(endpoint_port(endpoint))
    try:
        for attempt in range(10):
            runs = tmp_path / f"runs{attempt}"
            run = bench(scenario, runs, endpoint, connect=True)
            time.sleep(1.0)
            echo.send_signal(signal.SIGSTOP)
            assert run.wait(120) == 0, run.stderr.read()
            exited = time.time()
            (run_dir,) = runs.iterdir()
            assert exited - (run_dir / "summary.txt").stat().st_mtime < 2.0, f"attempt {attempt}"
            echo.send_signal(signal.SIGCONT)
            time.sleep(0.5)
    finally:
        echo.send_signal(signal.SIGCONT)
        echo.kill()
        echo.wait(10)


def test_watch_of_a_run_that_is_not_running_honours_wait(tmp_path):
    started = time.monotonic()
    watch = subprocess.run([sys.executable, "-m", "hil", "watch", "20990101T000000.000000Z-nosuch", "--wait", "2",
                            "--zenoh-listen", f"tcp/127.0.0.1:{free_port()}"], capture_output=True, text=True,
                           cwd=ROOT, timeout=60)
    assert watch.returncode == 1
    assert "is not running (unknown, or it has ended) within 2 s" in watch.stderr
    assert time.monotonic() - started < 30  # it gave up after --wait, it did not hang (seen: 10 min)


def test_the_run_flushes_its_last_samples_only_when_a_subscriber_listens():
    """`heard()` decides whether the close waits FLUSH_S for the summary to leave: false with nobody on the
    network, true once a subscriber in another session matches one of the run's channels."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    bench_session = open_session(ZenohOptions(listen=[endpoint], multicast_scouting=False))
    publisher = TelemetryPublisher(bench_session, "20990101T000000.000000Z-heard", {"scenario": "heard"})
    viewer = open_session(ZenohOptions(connect=[endpoint], multicast_scouting=False))
    try:
        assert not publisher.heard()
        subscriber = viewer.declare_subscriber("hil/20990101T000000.000000Z-heard/summary", lambda sample: None)
        deadline = time.monotonic() + 10
        while not publisher.heard() and time.monotonic() < deadline:
            time.sleep(0.05)
        assert publisher.heard()
        subscriber.undeclare()
        deadline = time.monotonic() + 10
        while publisher.heard() and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not publisher.heard()
    finally:
        viewer.close()
        publisher.close(Outcome(0, {}, ""))


def test_a_step_is_published_only_on_the_channels_a_subscriber_matches():
    """No sample is made for a channel nobody subscribes to; a subscriber's channel gets every step due at its rate
    (the state at 50 Hz: one a 20 ms step) from when it matches, and nothing once it leaves."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    bench_session = open_session(ZenohOptions(listen=[endpoint], multicast_scouting=False))
    run_id = "20990101T000000.000000Z-matched"
    publisher = TelemetryPublisher(bench_session, run_id, {"scenario": "matched"})
    viewer = open_session(ZenohOptions(connect=[endpoint], multicast_scouting=False))
    with Plant({}) as plant:
        resting = plant.state()
    zero = np.zeros(3)
    stepped_us: list[int] = []

    def step() -> None:
        t_us = 20_000 * (len(stepped_us) + 1)
        stepped_us.append(t_us)
        publisher.on_step(StepFrame(t_us, t_us * 1e-6, "mission", resting, None, SensorReadings(t_us), None,
                                    (0.0,) * 4, False, EnvironmentSample(zero, zero, zero, 0.0, (1.0,) * 4)))

    def wait_until(condition) -> None:
        deadline = time.monotonic() + 10
        while not condition() and time.monotonic() < deadline:
            time.sleep(0.02)

    received: list[tuple[str, int]] = []
    try:
        for _ in range(5):
            step()
        assert publisher.published == 0
        subscriber = viewer.declare_subscriber(
            f"hil/{run_id}/state", lambda sample: received.append((str(sample.key_expr),
                                                                     json.loads(bytes(sample.payload))["t_us"])))
        wait_until(lambda: publisher.heard_channels == {"state"})
        assert publisher.heard_channels == {"state"}
        for _ in range(5):
            step()
        wait_until(lambda: len(received) >= 5)
        assert received == [(f"hil/{run_id}/state", t_us) for t_us in stepped_us[5:]]
        assert publisher.published == 5
        subscriber.undeclare()
        wait_until(lambda: not publisher.heard_channels)
        step()
        assert publisher.published == 5
    finally:
        viewer.close()
        publisher.close(Outcome(0, {}, ""))
