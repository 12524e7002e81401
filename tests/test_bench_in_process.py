"""The bench in one process with its parts injected: the emulated flight code on a thread behind a real pty
(the same `BoardSession` and `BoardHandle` the CLI builds) and a sink that keeps every frame. No `hil run`,
no subprocess: a failure here points at the loop itself."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from firmware_interface.board import BoardKind, BoardSession
from firmware_interface.emulator import EmulatedBoard, build_config
from firmware_interface.link import Link, open_pty_pair
from firmware_interface.link.transports import SerialTransport
from hil.bench import Bench
from hil.connect import BoardHandle, emulator_config
from hil.exit_codes import EXIT_BOARD, EXIT_OK
from hil.frame import StepFrame
from hil.scenario.loader import load_scenario
from hil.scenario.schema import Scenario

pytestmark = pytest.mark.slow  # a few seconds of flight in lockstep

HOVER_M = 2.0


def hover(tmp_path: Path, seconds: float, end: str = "land") -> Scenario:
    path = tmp_path / "hover.yaml"
    path.write_text(f"name: in_process\nduration_s: {seconds}\nseed: 3\nend: {end}\n"
                    f"reference: {{type: hover, altitude_m: {HOVER_M}}}\n")
    return load_scenario(path)


class ThreadBoard:
    """The emulator's flight code served on a thread of this process, on the slave end of a pty."""

    def __init__(self, scenario: Scenario) -> None:
        pair = open_pty_pair()
        self.firmware = EmulatedBoard(Link(SerialTransport(pair.slave_path)), build_config(emulator_config(scenario)))
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self.firmware.run, args=(self.stop.is_set,), daemon=True)
        self.thread.start()
        session = BoardSession(Link(pair.master), BoardKind.EMULATOR, watchdog_s=1.0)
        session.wait_heartbeat(10.0)
        pair.release_slave()
        self.handle = BoardHandle(session, session, BoardKind.EMULATOR, "emulator thread", "emulator, smarc")

    def close(self) -> None:
        self.stop.set()
        self.thread.join(5.0)
        self.handle.close()
        self.firmware.link.close()


@pytest.fixture
def board_for() -> Iterator[list[ThreadBoard]]:
    boards: list[ThreadBoard] = []
    yield boards
    for board in boards:
        board.close()


def test_every_step_reaches_the_sink_once_in_order_and_the_vehicle_holds_the_hover(tmp_path, board_for):
    scenario = hover(tmp_path, 4.0)
    board_for.append(board := ThreadBoard(scenario))
    frames: list[StepFrame] = []
    result = Bench(scenario, board.handle, realtime=False, sinks=[frames.append]).run()
    assert (result.exit_code, result.reason) == (EXIT_OK, "completed")
    t_us = np.array([f.t_us for f in frames])
    assert t_us[0] == 4000 and np.all(np.diff(t_us) == 4000)  # 250 Hz: one frame per 4000 µs step, none lost
    mission = [f for f in frames if f.mission_t >= 2.0 and f.phase == "mission"]
    assert len(mission) > 200  # the last 2 s of the mission, at least
    altitude_m = np.array([-f.truth.pos_ned[2] for f in mission])
    assert abs(altitude_m.mean() - HOVER_M) < 0.2 and altitude_m.std() < 0.1
    assert all(f.armed for f in mission) and not frames[-1].armed and frames[-1].truth.on_ground
    assert result.metrics["phase_reached"] == "done"


def test_a_board_that_stops_answering_mid_mission_ends_the_run_with_the_frames_so_far(tmp_path, board_for):
    scenario = hover(tmp_path, 30.0, end="disarm")
    board_for.append(board := ThreadBoard(scenario))
    frames: list[StepFrame] = []

    def sink(frame: StepFrame) -> None:
        frames.append(frame)
        if frame.mission_t > 1.0:
            board.stop.set()  # the flight code stops; its end of the pty stays open, silent

    result = Bench(scenario, board.handle, realtime=False, sinks=[sink]).run()
    assert result.exit_code == EXIT_BOARD and result.reason.startswith("board/link failure")
    assert frames[-1].mission_t == pytest.approx(1.0, abs=0.1)  # the loop stopped where the board did
    assert np.all(np.diff([f.t_us for f in frames]) == 4000)
