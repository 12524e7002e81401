"""An emulator starved of its CPU mid-flight (a real-time process spinning on its core: the kernel leaves ordinary
work 5 % of each second) is silent for most of a second; in lockstep that is the machine's delay, not the board's,
so the flight goes on and records the same flight as unstarved, bit for bit."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import time
from collections import Counter
from contextlib import suppress
from dataclasses import dataclass, field

import pytest

from hil.boards.emulator import EmulatorTarget
from hil.host.process_cpu import scheduler_state
from hil.run.runner import RunOptions, run_scenario
from hil.scenario.loader import load_scenario
from tests.support.emulator_process import EmulatorWithItsProcess, may_raise_priority
from tests.support.recording_digest import simulated_digest

WATCHDOG_S = 0.5  # under the ~0.95 s the kernel's real-time throttling leaves a starved process silent
STARVE_AFTER_S, STARVE_FOR_S = 0.8, 1.0  # from the emulator's first heartbeat: its flight is under way by then
SPIN = "import os, sys\nos.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(5))\nsys.stdout.write('x')\n" \
       "sys.stdout.flush()\nwhile True: pass"


@dataclass
class StarveMidFlight:
    """The emulator pinned for `STARVE_FOR_S` to one CPU on which a SCHED_FIFO process spins, `STARVE_AFTER_S` after
    its first heartbeat; its scheduler states sampled meanwhile."""

    states: Counter[str | None] = field(default_factory=Counter)
    threads: list[threading.Thread] = field(default_factory=list)

    def __call__(self, pid: int) -> None:
        thread = threading.Thread(target=self._starve, args=(pid,), daemon=True)
        self.threads.append(thread)
        thread.start()

    def _starve(self, pid: int) -> None:
        time.sleep(STARVE_AFTER_S)
        cpus = os.sched_getaffinity(pid)
        cpu = max(cpus)
        spinner = subprocess.Popen([sys.executable, "-c", SPIN], stdout=subprocess.PIPE,
                                   preexec_fn=lambda: os.sched_setaffinity(0, {cpu}))  # noqa: PLW1509 - a test's child
        try:
            assert spinner.stdout is not None and spinner.stdout.read(1) == b"x"  # real-time and spinning now
            os.sched_setaffinity(pid, {cpu})
            end = time.monotonic() + STARVE_FOR_S
            while time.monotonic() < end:
                self.states[scheduler_state(pid)] += 1
                time.sleep(0.02)
        finally:
            spinner.kill()
            spinner.wait()
            with suppress(ProcessLookupError):  # the run ended meanwhile (it should not)
                os.sched_setaffinity(pid, cpus)


@pytest.mark.e2e
@pytest.mark.wallclock  # it takes one CPU from everything else for 1 s: alone, after the parallel part
@pytest.mark.skipif(not may_raise_priority(), reason="starving a process needs SCHED_FIFO: root or CAP_SYS_NICE")
def test_an_emulator_starved_of_its_cpu_mid_flight_is_waited_for_and_records_the_same_flight(tmp_path):
    scenario_path = tmp_path / "hold.yaml"
    scenario_path.write_text("name: hold\nduration_s: 30\nseed: 5\nend: disarm\n"
                             "reference: {type: hover, altitude_m: 2}\n")
    scenario = load_scenario(scenario_path)
    starved = StarveMidFlight()
    outcomes = {}
    for label, board in (("unstarved", EmulatorTarget()), ("starved", EmulatorWithItsProcess(starved))):
        outcomes[label] = run_scenario(scenario, RunOptions(board=board, runs_root=tmp_path / label, telemetry=None,
                                                            gcs=[], watchdog_s=WATCHDOG_S))
        assert outcomes[label].exit_code == 0, outcomes[label].reason
    for thread in starved.threads:
        thread.join()
    assert starved.states["R"] > 0.8 * sum(starved.states.values())  # waiting for its CPU, as the watchdog saw
    timing = json.loads((outcomes["starved"].run_dir / "metrics.json").read_text())["timing"]
    assert timing["step_wall_us"]["max"] > 1.2 * WATCHDOG_S * 1e6  # a silence over the watchdog was waited out
    assert simulated_digest(outcomes["starved"].run_dir) == simulated_digest(outcomes["unstarved"].run_dir)
