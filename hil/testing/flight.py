"""One flight for a test, in the test's own process: the runner as `hil run` calls it, without the printing.

In process rather than as `hil run` in a child: measured on this 2-core machine, a 3 s hover took 1.7-1.8 s in
process against 2.2-2.6 s as a process (the bench's imports, ~0.5 s, and the interpreter's start, paid per item),
and nothing is lost to isolation: the emulator and PX4 are child processes either way, each run opens and closes
its own pty, links and (with telemetry) Zenoh session, and the runner restores the signal handlers and the heap it
froze. A stop signal reaches the run first, which lands and closes its files, and then pytest, which ends the
session (a child would be killed by subprocess.run 0.25 s after Ctrl-C, its recording cut).
"""

from __future__ import annotations

import fcntl
import hashlib
import tempfile
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from hil.exit_codes import EXIT_INTERRUPTED, EXIT_OK
from hil.loop.frame import StepFrame
from hil.loop.sink import Outcome
from hil.scenario.schema import Scenario
from hil.testing.results import Event, HilRun, HilRunError, Metrics
from hil.testing.settings import Board, HilSettings


class EventLog:
    """A sink that keeps the run's events (the board's texts among them) for the test's messages."""

    def __init__(self) -> None:
        self.events: list[Event] = []

    def on_step(self, frame: StepFrame) -> None:
        """Not wanted."""

    def on_event(self, t_us: int, text: str) -> None:
        self.events.append(Event(t_us * 1e-6, text))

    def close(self, outcome: Outcome) -> None:
        """Nothing to close."""


def load(path: Path) -> Scenario:
    """The scenario file, or HilRunError with the loader's lines (file, line, field)."""
    from hil.scenario.loader import ScenarioError, load_scenario

    try:
        return load_scenario(path)
    except ScenarioError as exc:
        raise HilRunError(str(exc)) from None


def with_changes(scenario: Scenario, changes: Mapping[str, Any], given_by: str) -> Scenario:
    """The scenario with fields replaced by their path (`seed`, `board.controller`, `wind.gusts[0].peak_ned`, as a
    sweep names them) and validated again; HilRunError naming the field and what gave it otherwise."""
    from pydantic import ValidationError

    from hil.scenario.loader import describe
    from hil.sweep.design import set_path

    if not changes:
        return scenario
    data = scenario.model_dump()
    try:
        for path, value in changes.items():
            set_path(data, path, value)
        return Scenario.model_validate(data)
    except KeyError as exc:  # a path to no field (PathError)
        raise HilRunError(f"{scenario.name}: {given_by}: {exc}") from None
    except ValidationError as exc:
        raise HilRunError("\n".join(f"{scenario.name}: {given_by}: {'.'.join(map(str, e['loc']))}: {describe(e)}"
                                    for e in exc.errors(include_url=False))) from None


@contextmanager
def _board_to_itself(board: Board) -> Iterator[None]:
    """A board on a port is one board: runs on it, from any process (pytest-xdist's workers), take turns through a
    lock file named after it. The emulator and PX4 started by the bench are a fresh process per run."""
    if not board.spec.startswith("port:"):
        yield
        return
    name = hashlib.sha256(board.spec.encode()).hexdigest()[:16]
    with open(Path(tempfile.gettempdir()) / f"hil-board-{name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        yield


def _report(run_dir: Path, exit_code: int, wanted: str) -> Path | None:
    from hil.reports.html import NoFlightData, write_report

    if wanted == "none" or (wanted == "failed" and exit_code == EXIT_OK):
        return None
    try:
        return write_report(run_dir)
    except NoFlightData:
        return None


def fly(scenario: Scenario, board: Board, runs_root: Path, settings: HilSettings) -> HilRun:
    """Fly the scenario on the board, its run directory under `runs_root`, with no ground-station relay and with
    Zenoh only when asked; a stop signal during the flight ends the session once the run has closed."""
    from hil.outputs.zenoh_session import ZenohOptions
    from hil.run.runner import RunOptions, run_scenario

    events = EventLog()
    options = RunOptions(board=board.target, runs_root=runs_root, keep_failed=True, gcs=[],
                         telemetry=ZenohOptions() if settings.telemetry else None)
    with _board_to_itself(board):
        outcome = run_scenario(scenario, options, sinks=[events])
    if outcome.exit_code == EXIT_INTERRUPTED:
        raise KeyboardInterrupt(outcome.reason)
    return HilRun(scenario, board.spec, board.target.policy(scenario).autopilot, int(outcome.exit_code), outcome.reason,
                  outcome.failures, outcome.run_dir, outcome.summary, Metrics(outcome.metrics), events.events,
                  _report(outcome.run_dir, outcome.exit_code, settings.report))

