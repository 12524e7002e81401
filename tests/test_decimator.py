"""The live views' decimation: per channel in simulated time, and for a view a person watches, capped in wall
time too (counts worked out by hand from the rates)."""

from __future__ import annotations

import time
from itertools import pairwise

from hil.outputs.telemetry import Decimator

STEP_US = 4000  # a 250 Hz bench


def test_a_50_hz_channel_passes_every_fifth_250_hz_step_and_a_sparse_one_every_sample():
    """The first sample (4 ms) opens the schedule, then one every 20 ms up to 1 s: 1 + 50 in the first second."""
    decimator = Decimator({"state": 50.0})
    passed = [k for k in range(1, 251) if decimator.passes("state", k * STEP_US)]
    assert passed[:3] == [1, 5, 10] and len(passed) == 51 and all(b - a == 5 for a, b in pairwise(passed[1:]))
    assert all(decimator.passes("board/statustext", k * STEP_US) for k in range(1, 251))


def test_the_wall_clock_cap_thins_a_lockstep_stream_and_leaves_sparse_channels_alone():
    """10 simulated seconds offered as fast as the loop goes: 1 + 500 samples pass in simulated time, but
    at most one per wall-clock period (1 s here) plus the first."""
    capped, uncapped = Decimator({"state": 50.0}, max_wall_hz=1.0), Decimator({"state": 50.0})
    started = time.monotonic()
    capped_count = sum(capped.passes("state", k * STEP_US) for k in range(1, 2501))
    elapsed_s = time.monotonic() - started
    assert sum(uncapped.passes("state", k * STEP_US) for k in range(1, 2501)) == 501
    assert 1 <= capped_count <= 1 + int(elapsed_s) + 1
    assert all(capped.passes("events", k * STEP_US) for k in range(2501, 2600))


def test_paced_in_real_time_the_cap_changes_nothing():
    """50 samples per simulated second offered at 50 per wall second, under a 60 Hz cap: all pass."""
    decimator = Decimator({"state": 50.0}, max_wall_hz=60.0)
    count = 0
    for k in range(1, 51):
        offered_s = time.monotonic()
        count += decimator.passes("state", k * 5 * STEP_US)  # one 50 Hz sample per ≥ 20 ms of wall time
        while time.monotonic() < offered_s + 0.02:  # a stall only lengthens the gap
            time.sleep(0.001)
    assert count == 50
