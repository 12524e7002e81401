"""A lockstep board that is silent because its process waits for a CPU is waited for; one asleep, stopped or gone is
not (`firmware_interface.board_watchdog`), with the process's scheduler state read from Linux's /proc."""

from __future__ import annotations

import functools
import signal
import subprocess
import sys
import time
from collections.abc import Iterator

import pytest

from firmware_interface import board_watchdog
from firmware_interface import hil_codec as codec
from firmware_interface.board import SIMULATED, BoardError, BoardSession
from hil.host.process_cpu import scheduler_state
from tests.support.scripted_board import ScriptedBoard

STEP_US = 50_000


def started(argv: list[str]) -> Iterator[subprocess.Popen[bytes]]:
    process = subprocess.Popen(argv)
    try:
        yield process
    finally:
        process.kill()
        process.wait()


@pytest.fixture
def spinning() -> Iterator[subprocess.Popen[bytes]]:
    """A process that always has work: runnable (R) whenever the scheduler is asked."""
    yield from started([sys.executable, "-c", "while True: pass"])


@pytest.fixture
def asleep() -> Iterator[subprocess.Popen[bytes]]:
    yield from started(["sleep", "60"])


def state_within(pid: int, wanted: str, timeout_s: float = 5.0) -> str | None:
    """The state once it is `wanted` (a process just started is still loading), or the last one seen."""
    deadline = time.monotonic() + timeout_s
    state = scheduler_state(pid)
    while state != wanted and time.monotonic() < deadline:
        time.sleep(0.01)
        state = scheduler_state(pid)
    return state


def test_the_scheduler_states_are_the_kernels(spinning, asleep):
    assert state_within(spinning.pid, "R") == "R"
    assert state_within(asleep.pid, "S") == "S"
    spinning.send_signal(signal.SIGSTOP)
    assert state_within(spinning.pid, "T") == "T"
    asleep.kill()
    asleep.wait()
    assert scheduler_state(asleep.pid) is None  # reaped: no /proc entry


@pytest.fixture
def booted() -> Iterator[tuple[ScriptedBoard, BoardSession, int]]:
    """A session in lockstep with a scripted board past its boot allowance, on a 0.2 s watchdog."""
    board = ScriptedBoard()
    session = BoardSession(board.start(), SIMULATED, watchdog_s=0.2)
    session.wait_heartbeat(5.0)
    board.send_heartbeat = False  # from now on only the replies break a silence
    t_us = 0
    while session.watchdog.booting:
        t_us += STEP_US
        session.exchange(codec.SensorReadings(t_us, (0, 0, -9.81), (0, 0, 0)))
    yield board, session, t_us + STEP_US
    board.stop()


def test_a_silent_board_whose_process_is_runnable_is_waited_for(booted, spinning):
    board, session, t_us = booted
    session.watchdog.process_state = functools.partial(scheduler_state, spinning.pid)
    board.stall_s = 0.6  # three times the watchdog
    began = time.monotonic()
    out = session.exchange(codec.SensorReadings(t_us, (0, 0, -9.81), (0, 0, 0)))
    assert out is not None and out.t_us == t_us  # the reply to this very step, once the board spoke again
    assert time.monotonic() - began >= 0.6


def test_the_same_silence_of_a_board_process_asleep_ends_the_run_and_says_so(booted, asleep):
    board, session, t_us = booted
    session.watchdog.process_state = functools.partial(scheduler_state, asleep.pid)
    board.stall_s = 0.6
    began = time.monotonic()
    with pytest.raises(BoardError, match=r"board silent for 0\.2\d s on .* \(watchdog 0\.20 s; its process asleep\)"):
        session.exchange(codec.SensorReadings(t_us, (0, 0, -9.81), (0, 0, 0)))
    assert time.monotonic() - began < 0.5


def test_a_board_process_runnable_for_too_long_counts_as_hung(booted, spinning, monkeypatch):
    board, session, t_us = booted
    monkeypatch.setattr(board_watchdog, "RUNNABLE_MAX_S", 0.5)
    session.watchdog.process_state = functools.partial(scheduler_state, spinning.pid)
    board.answer_sensors = False  # never answers again
    began = time.monotonic()
    with pytest.raises(BoardError, match=r"\(watchdog 0\.20 s; its process runnable past 0\.5 s\)"):
        session.exchange(codec.SensorReadings(t_us, (0, 0, -9.81), (0, 0, 0)))
    assert 0.5 <= time.monotonic() - began < 2.0
