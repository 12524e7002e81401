"""`hil run` end to end on the emulator: scenarios, determinism, recording, a dying board, Ctrl-C."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
import yaml
from mcap.reader import make_reader

from firmware_interface.emulator.replay import replay_run
from tests.support.cli_runs import REPORTED, emulator_pids, run, wait_flying
from tests.support.recording_digest import (
    CHECKSUMS,
    numeric_platform,
    recorded_here,
    shipped_scenarios,
    simulated_content,
    simulated_content_by_the_mcap_reader,
    simulated_digest,
)

pytestmark = pytest.mark.e2e
ROOT = Path(__file__).resolve().parent.parent
SHIPPED = shipped_scenarios()
RECORDED = json.loads(CHECKSUMS.read_text())
PER_STEP = ("hil/state", "hil/sensors/imu", "hil/actuators", "hil/environment", "hil/timing")


def read_mcap(path: Path) -> list[tuple[str, int, bytes]]:
    with open(path, "rb") as f:
        return [(ch.topic, msg.log_time, msg.data) for _, ch, msg in make_reader(f).iter_messages()]


# link_faults flies paced on the wall clock and is judged on its attitude, so it runs alone with the `wallclock`
# tests. Beside other flights it broke its 3° bound three times (4.04°, 7.47°, and 3.71° in CI with the starved-board
# wait on: no wait, the bench slipped twice, the board's estimate 2.7° off the truth; cause not found).
WALL_CLOCK_JUDGED = {"link_faults"}


@pytest.mark.parametrize("scenario", [pytest.param(s, marks=pytest.mark.wallclock) if s.stem in WALL_CLOCK_JUDGED
                                      else s for s in SHIPPED], ids=lambda p: p.stem)
def test_shipped_scenario_flies_on_the_emulator_with_its_expectations_met(scenario, shipped_flight):
    result, run_dir = shipped_flight(scenario)
    assert result.returncode == 0, result.stdout + result.stderr
    summary = (run_dir / "summary.txt").read_text()
    assert "result: PASS" in summary and "expectations: met" in summary
    assert max(len(line) for line in summary.splitlines()) <= 100  # a terminal's width, no wrapping
    metrics = json.loads((run_dir / "metrics.json").read_text())
    assert metrics["exit_code"] == 0 and metrics["phase_reached"] == "done"
    assert {"scenario.yaml", "meta.json", "recording.mcap", "metrics.json", "summary.txt"} <= {
        p.name for p in run_dir.iterdir()}
    if scenario.stem == REPORTED:  # the one flown as plain `hil run FILE`: its page comes with it
        assert (run_dir / "report.html").is_file() and f"report: {run_dir / 'report.html'}" in result.stdout


@pytest.mark.parametrize("scenario", [s for s in SHIPPED if s.stem not in RECORDED["not_reproducible"]],
                         ids=lambda p: p.stem)
def test_shipped_scenario_flies_bit_for_bit_as_before_the_last_refactor(scenario, shipped_flight):
    _, run_dir = shipped_flight(scenario)
    recorded = recorded_here()
    if recorded is None:
        pytest.skip(f"{CHECKSUMS.name} has no digests for this numeric platform, {numeric_platform()}: floating "
                    "point differs in the last bit across platforms "
                    "(add them: python -m tests.support.recording_digest)")
    if scenario.stem not in recorded["scenarios"]:
        pytest.skip(f"{CHECKSUMS.name} has no digest of {scenario.stem} for this numeric platform yet (a scenario "
                    "newer than its set: add it with python -m tests.support.recording_digest)")
    assert simulated_digest(run_dir) == recorded["scenarios"][scenario.stem], (
        f"{scenario.stem} no longer flies bit for bit as at {recorded['recorded_at_revision']}")


@pytest.mark.parametrize("scenario", [s for s in SHIPPED if s.stem not in RECORDED["not_reproducible"]],
                         ids=lambda p: p.stem)
def test_the_emulator_answers_its_flights_reads_replayed_in_process_as_it_answered_them(scenario, shipped_flight):
    """What the emulator sends depends only on the bytes it reads: the bench's frames of the flight (its tlog),
    fed read by read to an emulator in this process, bring the replies it sent over the pty, byte for byte."""
    _, run_dir = shipped_flight(scenario)
    replay = replay_run(run_dir)
    assert replay.reads >= 250 * json.loads((run_dir / "metrics.json").read_text())["timing"]["sim_s"] - 1
    assert replay.first_difference is None, f"the replies differ from byte {replay.first_difference} on"


def test_a_replay_on_another_controller_answers_otherwise(shipped_flight, tmp_path):
    """The replay's check can fail: the same reads flown by another of the paper's laws change the motors of the
    first armed step's reply."""
    _, run_dir = shipped_flight(ROOT / "scenarios" / "hover.yaml")
    for name in ("emulator.yaml", "link.tlog"):
        shutil.copy(run_dir / name, tmp_path)
    config = yaml.safe_load((tmp_path / "emulator.yaml").read_text())
    assert config["controller"] == "smarc"
    (tmp_path / "emulator.yaml").write_text(yaml.safe_dump({**config, "controller": "smpid"}))
    replay = replay_run(tmp_path)
    assert replay.first_difference is not None and len(replay.sent) > replay.first_difference > 1000


def test_the_emulators_own_cpu_per_step_is_measured_and_within_the_step(shipped_flight):
    """The board's CPU share of a lockstep step: a one-threaded emulator cannot use more CPU than the wall
    time of the steps it answered, and reading, decoding, estimating, controlling, encoding and writing a step
    in Python take more than 5 us."""
    result, run_dir = shipped_flight(ROOT / "scenarios" / "hover.yaml")
    timing = json.loads((run_dir / "metrics.json").read_text())["timing"]
    steps = round(timing["sim_s"] * 250)
    assert 5.0 < timing["board_cpu_us_per_step"] < timing["wall_s"] / steps * 1e6
    assert f"board's own CPU: {timing['board_cpu_us_per_step']:.0f} us per step" in result.stdout


def short_hover(tmp_path: Path, seconds: float = 3.0) -> Path:
    path = tmp_path / "short.yaml"
    path.write_text(f"name: short\nduration_s: {seconds}\nseed: 4\nreference: {{type: hover, altitude_m: 3}}\n"
                    "wind: {steady_ned: [1, 0, 0], turbulence: {intensity: light}}\n")
    return path


@pytest.fixture(scope="module")
def same_seed_twice(tmp_path_factory) -> tuple[Path, Path, tuple[int, int]]:
    """One short scenario flown twice with the same seed (no report: the recordings are what is checked), and the
    machine's monotonic clock (µs) read before and after the two flights."""
    tmp = tmp_path_factory.mktemp("same_seed")
    scenario = short_hover(tmp)
    before_us = time.monotonic_ns() // 1000
    flights = [run(scenario, tmp / name, "--no-report") for name in ("a", "b")]
    after_us = time.monotonic_ns() // 1000
    for result, _ in flights:
        assert result.returncode == 0, result.stdout + result.stderr
    return flights[0][1], flights[1][1], (before_us, after_us)


def test_same_scenario_and_seed_give_identical_recordings_in_lockstep(same_seed_twice):
    first, second, _ = same_seed_twice
    a = simulated_content(first)
    assert a == simulated_content(second)
    assert len(a) > 10_000
    assert a == simulated_content_by_the_mcap_reader(first)  # the digests' fast read is the indexed reader's


def test_recording_opens_with_the_mcap_reader_and_has_every_channel_at_full_rate(same_seed_twice):
    run_dir = same_seed_twice[0]  # a whole run, landed and disarmed
    messages = read_mcap(run_dir / "recording.mcap")
    counts = Counter(topic for topic, _, _ in messages)
    steps = counts["hil/state"]
    last_t_us = max(json.loads(data)["t_us"] for topic, _, data in messages if topic == "hil/state")
    assert steps == last_t_us // 4000  # one state sample per 4 ms bench step, none missing
    for topic in PER_STEP:
        assert counts[topic] == steps
    assert counts["hil/sensors/mag"] == pytest.approx(steps * 100 / 250, abs=2)  # px4_sitl mag at 100 Hz
    assert counts["hil/sensors/baro"] == pytest.approx(steps * 50 / 250, abs=2)
    assert counts["hil/sensors/gps"] == pytest.approx(steps * 5 / 250, abs=2)
    assert counts["hil/reference"] > 0 and counts["hil/board/heartbeat"] > 0 and counts["hil/events"] >= 5


def test_each_steps_start_is_recorded_on_the_machines_monotonic_clock(same_seed_twice):
    """hil/timing's start_monotonic_us is CLOCK_MONOTONIC (the clock PX4's log keeps on its HITL path): every step
    of the first flight starts between this process's readings of that clock around the flights, each after the
    one before it has ended (its step_wall_us later at least)."""
    first, _, (before_us, after_us) = same_seed_twice
    steps = [json.loads(data) for topic, _, data in read_mcap(first / "recording.mcap") if topic == "hil/timing"]
    starts_us = np.array([s["start_monotonic_us"] for s in steps])
    assert before_us < starts_us[0] and starts_us[-1] < after_us
    assert np.all(np.diff(starts_us) >= np.array([s["step_wall_us"] for s in steps[:-1]]) - 1)  # rounded to 1 µs


@pytest.mark.usefixtures("fresh_emulators")
def test_killing_the_emulator_mid_run_exits_3_quickly_with_the_recording_intact(tmp_path):
    scenario = short_hover(tmp_path, seconds=120.0)
    runs = tmp_path / "runs"
    proc = subprocess.Popen([sys.executable, "-m", "hil", "run", "--no-report", str(scenario), "--runs", str(runs)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    wait_flying(runs)
    (emulator,) = emulator_pids(proc.pid)
    os.kill(emulator, signal.SIGKILL)
    killed = time.monotonic()
    proc.wait(30)
    elapsed = time.monotonic() - killed
    assert proc.returncode == 3
    # noticed by the lost pty at once, not by a timeout (the link watchdog alone would take 1 s, a
    # hang forever); the margin is for a loaded 2-core machine closing Zenoh and the recording
    assert elapsed < 3.0, f"took {elapsed:.2f} s"
    run_dir = max(runs.iterdir())
    summary = (run_dir / "summary.txt").read_text()
    assert "board/link failure" in summary and "closed" in summary
    assert len(read_mcap(run_dir / "recording.mcap")) > 1000


def test_ctrl_c_exits_130_and_says_so_in_the_summary(tmp_path):
    runs = tmp_path / "runs"
    proc = subprocess.Popen([sys.executable, "-m", "hil", "run", "--no-report", str(short_hover(tmp_path, 120.0)),
                             "--runs", str(runs)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    wait_flying(runs)
    proc.send_signal(signal.SIGINT)
    proc.wait(30)
    assert proc.returncode == 130
    run_dir = max(runs.iterdir())
    assert "interrupted (Ctrl-C)" in (run_dir / "summary.txt").read_text()
    assert len(read_mcap(run_dir / "recording.mcap")) > 1000
