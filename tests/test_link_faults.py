"""Link faults between the bench and the board: the injector against its own definition, and in flight on
the emulator (real pty, real MAVLink): loss and latency ridden through, an outage that fires the failsafe."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from firmware_interface.link.faults import FaultSpec, LinkFaults
from tests.support.summary_text import summary_field

pytestmark = pytest.mark.e2e  # drives the bench's processes (hil, the emulator) end to end

ROOT = Path(__file__).resolve().parent.parent


def frames(n: int) -> list[bytes]:
    return [bytes([0xFD, i % 256, 0, 0, 0, 1, 1, 0, 0, 0]) for i in range(n)]


def test_loss_drops_the_stated_share_in_bursts_of_the_stated_length():
    faults = LinkFaults([FaultSpec("loss", "to_board", probability=0.01, burst_frames=5)], np.random.default_rng(1))
    faults.window_s = 1.0
    sent = frames(200_000)
    out = [faults.outgoing(f) for f in sent]
    lost = faults.counts["to_board_lost"]
    assert sum(1 for o in out if not o) == lost
    # a burst starts at a frame with probability p: the share lost is 5p / (1 + 4p)
    assert lost / len(sent) == __import__("pytest").approx(5 * 0.01 / (1 + 4 * 0.01), rel=0.05)
    runs = np.diff(np.flatnonzero(np.diff(np.r_[1, [bool(o) for o in out], 1])))[::2]
    assert set(runs) <= {5, 10, 15}  # whole bursts (back-to-back bursts join)


def test_latency_delays_by_the_stated_time_and_never_reorders():
    faults = LinkFaults([FaultSpec("latency", "from_board", delay_s=0.02, jitter_s=0.005)], np.random.default_rng(2))
    faults.window_s = 1.0
    arrivals: list[tuple[float, bytes]] = []
    sent = frames(1000)
    for step, frame in enumerate(sent):
        faults.now_s = step * 0.004
        arrivals += [(faults.now_s, f) for f in faults.incoming_frames([frame])]
    for k in range(60):  # let the queue drain
        faults.now_s = (len(sent) + k) * 0.004
        arrivals += [(faults.now_s, f) for f in faults.incoming_frames([])]
    assert [f for _, f in arrivals] == sent  # all of them, in order
    delays = np.array([t for t, _ in arrivals]) - np.arange(len(sent)) * 0.004
    assert delays.min() >= 0.015 - 1e-9 and delays.max() <= 0.025 + 0.004 + 1e-9
    assert abs(np.median(delays) - 0.022) < 0.004  # 20 ms on the 4 ms step grid


def test_corruption_flips_one_bit_per_hit_and_outage_drops_everything_in_its_window():
    faults = LinkFaults([FaultSpec("corruption", "from_board", byte_error_rate=0.01),
                         FaultSpec("outage", "to_board", start_s=10.0, end_s=11.0)], np.random.default_rng(3))
    data = bytes(100_000)
    faults.window_s = 0.0
    corrupted = faults.incoming_bytes(data)
    flipped = [b for b in corrupted if b]
    assert len(flipped) == faults.counts["from_board_bytes_corrupted"]
    assert all(b.bit_count() == 1 for b in flipped) and abs(len(flipped) / len(data) - 0.01) < 0.002
    faults.window_s = 10.5
    assert faults.outgoing(b"frame") == b"" and faults.counts["to_board_outage_dropped"] == 1
    faults.window_s = 11.0
    assert faults.outgoing(b"frame") == b"frame"


def fly(tmp_path: Path, text: str) -> tuple[subprocess.CompletedProcess[str], dict]:
    scenario = tmp_path / "faults.yaml"
    scenario.write_text(text)
    run = subprocess.run([sys.executable, "-m", "hil", "run", "--no-report", str(scenario),
                          "--runs", str(tmp_path / "runs"), "--no-telemetry", "--no-gcs"],
                         capture_output=True, text=True, timeout=300, cwd=ROOT)
    metrics = json.loads(next((tmp_path / "runs").iterdir()).joinpath("metrics.json").read_text())
    return run, metrics


@pytest.mark.wallclock  # paced and judged on its attitude: alone, as link_faults.yaml (test_hil_run.py)
def test_five_percent_loss_and_latency_are_ridden_through_with_the_figures_in_metrics(tmp_path):
    # disarmed where it hovers at the end: the landing after it (~9 s of wall clock) is judged by nothing here
    run, metrics = fly(tmp_path, "name: lossy\nduration_s: 4\nseed: 5\nend: disarm\n"
                                 "reference: {type: hover, altitude_m: 3}\n"
                                 "faults:\n  link:\n    - {kind: loss, probability: 0.05}\n"
                                 "    - {kind: latency, delay_ms: 2, jitter_ms: 1}\n"
                                 "expect: {settle_s: 1, max_error_m: 0.8, max_attitude_error_deg: 3}\n")
    assert run.returncode == 0, run.stdout + run.stderr
    injected = metrics["link_faults"]["injected"]
    for direction in ("to_board", "from_board"):
        share = injected[f"{direction}_lost"] / injected[f"{direction}_frames_in_fault_windows"]
        assert 0.04 < share < 0.06, (direction, share)
    assert injected["from_board_lost"] > 0 and injected["to_board_delayed"] > 0
    assert metrics["link_faults"]["board_failsafe"] == []
    assert metrics["timing"]["realtime_factor"] < 1.05  # paced in real time, as a board on its own clock


def test_a_one_second_outage_fires_the_emulators_failsafe_and_ends_the_run_with_the_reason(tmp_path):
    # the outage 0.5 s into the hold at 3 m (the mission clock starts at the top of the take-off): in flight, and
    # on the wall clock (link faults pace the run in real time) as soon as the vehicle is up
    run, metrics = fly(tmp_path, "name: outage\nduration_s: 8\nseed: 5\nreference: {type: hover, altitude_m: 3}\n"
                                 "faults:\n  link:\n"
                                 "    - {kind: outage, direction: to_board, start_s: 0.5, end_s: 1.5}\n")
    assert run.returncode == 1, run.stdout + run.stderr
    ended = summary_field(run.stdout, "ended")
    assert "the board disarmed in flight" in ended and "Failsafe: no HIL_SENSOR" in ended
    failsafe = metrics["link_faults"]["board_failsafe"]
    assert failsafe and "Failsafe" in failsafe[0]["text"]
    assert metrics["link_faults"]["injected"]["to_board_outage_dropped"] > 200  # 1 s of 250 Hz sensor frames
