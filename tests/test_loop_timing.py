"""The loop's timing: each stretch of wall time charged to one part, the parts adding up to the step; pacing
figures only for a paced run."""

from __future__ import annotations

import os
import threading
import time

import pytest
from pymavlink.dialects.v20 import common

from firmware_interface.link import Link
from firmware_interface.link.transports import FdTransport
from hil.loop.timing import LoopTiming


def test_laps_charge_each_stretch_to_its_part_and_add_up_to_the_whole():
    timer = LoopTiming(breakdown_s={"a": 0.0, "b": 0.0})
    totals = timer.breakdown_s
    started = timer.start()
    time.sleep(0.02)
    timer.lap("a")
    time.sleep(0.01)
    end = timer.lap("b")
    timer.start()
    timer.lap("a")  # a second step adds to the same totals
    assert totals["a"] >= 0.02 and totals["b"] >= 0.01
    assert totals["a"] + totals["b"] == pytest.approx(end - started, abs=1e-3)


def test_the_longest_part_of_the_step_is_kept_until_the_next_start():
    timer = LoopTiming(breakdown_s={"a": 0.0, "b": 0.0})
    timer.start()
    timer.lap("a")
    time.sleep(0.01)
    timer.lap("b")
    part, seconds = timer.longest
    assert part == "b" and seconds >= 0.01
    timer.start()
    assert timer.longest == ("", 0.0)


def test_pacing_figures_appear_only_for_a_paced_run():
    timing = LoopTiming()
    for start in (0.0, 0.004, 0.0085, 0.012):
        timing.add_step_start(start, 0.004)
        timing.add_step(1e-4, None)
    timing.sim_s, timing.wall_s = 2.0, 1.0
    assert "period_jitter_us" not in timing.figures(paced=False)
    figures = timing.figures(paced=True)
    assert figures["realtime_factor"] == 2.0
    assert figures["period_jitter_us"]["max"] == pytest.approx(500, rel=0.02)  # 4.5 ms vs 4 ms


def test_a_lap_charges_the_time_a_real_read_waited_to_its_own_part():
    """A link reading a pipe whose writer sends a HEARTBEAT 30 ms after the step began: the time blocked in the
    read goes to the waited part, the rest of the lap (5 ms of work before the wait) to the lap's part, and the
    two add up to the lap."""
    read_fd, write_fd = os.pipe()
    frame = bytes(common.MAVLink_heartbeat_message(2, 12, 0, 0, 4, 3).pack(common.MAVLink(None, 1, 1)))
    link = Link(FdTransport(read_fd, "pipe"))
    timer = LoopTiming(breakdown_s={"reply": 0.0, "wait": 0.0})
    writer = threading.Timer(0.03, os.write, (write_fd, frame))
    started = timer.start()
    writer.start()
    time.sleep(0.005)
    waited_before = link.waited_s
    messages = link.receive(1.0)
    end = timer.lap("reply", "wait", link.waited_s - waited_before)
    writer.join()
    link.close()
    os.close(write_fd)
    assert [m.get_type() for m in messages] == ["HEARTBEAT"]
    assert timer.breakdown_s["wait"] >= 0.02 and timer.breakdown_s["reply"] >= 0.005
    assert timer.breakdown_s["wait"] + timer.breakdown_s["reply"] == pytest.approx(end - started, abs=1e-6)
