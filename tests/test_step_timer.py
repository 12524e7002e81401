"""StepTimer charges each stretch of wall time to one part, and the parts add up to the step."""

from __future__ import annotations

import time

import pytest

from hil.loop.step_timer import StepTimer


def test_laps_charge_each_stretch_to_its_part_and_add_up_to_the_whole():
    totals = {"a": 0.0, "b": 0.0}
    timer = StepTimer(totals)
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
    timer = StepTimer({"a": 0.0, "b": 0.0})
    timer.start()
    timer.lap("a")
    time.sleep(0.01)
    timer.lap("b")
    part, seconds = timer.longest
    assert part == "b" and seconds >= 0.01
    timer.start()
    assert timer.longest == ("", 0.0)
