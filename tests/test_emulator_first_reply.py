"""The emulator's first lockstep replies are waited for as long as any later one: a machine too busy to run the
emulator when the first HIL_SENSOR goes out (three test files at a time on two cores shifted manual_control_loss's
first replies by two steps, and its recording with them) still records the same flight, bit for bit."""

from __future__ import annotations

import json
import os
import signal
import threading
from dataclasses import dataclass, field

import pytest

from hil.boards.emulator import EmulatorTarget
from hil.run.runner import RunOptions, run_scenario
from hil.scenario.loader import load_scenario
from tests.support.emulator_process import EmulatorWithItsProcess
from tests.support.recording_digest import simulated_digest

STALL_S = 0.3  # thirty steps' worth of the 10 ms a booting PX4 SITL's first replies are given


@dataclass(frozen=True)
class StopAtItsStart:
    """The emulator stopped (SIGSTOP: no CPU at all) from its first heartbeat for `stall_s`, so that the bench's
    first HIL_SENSOR waits in the pty."""

    stall_s: float
    resumes: list[threading.Timer] = field(default_factory=list)

    def __call__(self, pid: int) -> None:
        os.kill(pid, signal.SIGSTOP)
        resume = threading.Timer(self.stall_s, os.kill, (pid, signal.SIGCONT))
        self.resumes.append(resume)
        resume.start()


@pytest.mark.e2e
def test_an_emulator_slow_to_answer_its_first_frame_records_the_same_flight(tmp_path):
    scenario_path = tmp_path / "hold.yaml"
    scenario_path.write_text("name: hold\nduration_s: 1\nseed: 5\nend: disarm\n"
                             "reference: {type: hover, altitude_m: 2}\n")
    scenario = load_scenario(scenario_path)
    stalled = StopAtItsStart(STALL_S)
    outcomes = {}
    for label, board in (("at once", EmulatorTarget()), ("stopped at its start", EmulatorWithItsProcess(stalled))):
        outcomes[label] = run_scenario(scenario, RunOptions(board=board, runs_root=tmp_path / label, telemetry=None,
                                                            gcs=[]))
        assert outcomes[label].exit_code == 0, outcomes[label].reason
    for resume in stalled.resumes:
        resume.join()
    step_wall_max_us = json.loads((outcomes["stopped at its start"].run_dir / "metrics.json").read_text())[
        "timing"]["step_wall_us"]["max"]
    assert step_wall_max_us > 0.8 * STALL_S * 1e6  # the bench waited out the stall in one step
    assert simulated_digest(outcomes["stopped at its start"].run_dir) == simulated_digest(outcomes["at once"].run_dir)
