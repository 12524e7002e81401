"""A flown run as a test sees it: the outcome, the metrics by attribute (`run.metrics.position_error_m.z.max_abs`),
the run's events, the recording read back on demand; and what pytest prints and JUnit keeps of it."""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from functools import cached_property
from itertools import groupby
from pathlib import Path
from typing import TYPE_CHECKING, Any

from hil.exit_codes import Exit

if TYPE_CHECKING:
    from hil.reports.rundata import Flight, RunData
    from hil.scenario.schema import Scenario

BOARD_TEXTS = 5  # the board's last texts an error quotes
BOARD_LOGS = ("emulator.log", "px4.log")


class HilRunError(Exception):
    """A scenario that cannot be flown, or a run that ended without a verdict on the flight: the message says why,
    one line per problem, and where the run directory is."""


class Metrics(Mapping[str, Any]):
    """metrics.json by attribute as well as by key; a name it does not hold raises AttributeError naming those it
    does (a run that never reached its mission has no tracking errors)."""

    def __init__(self, tree: Mapping[str, Any]) -> None:
        self._tree = dict(tree)

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__") or name == "_tree":
            raise AttributeError(name)
        if name not in self._tree:
            raise AttributeError(f"no metric '{name}' in this run; it has {', '.join(self._tree) or 'none'}")
        return self[name]

    def __getitem__(self, key: str) -> Any:
        value = self._tree[key]
        return Metrics(value) if isinstance(value, Mapping) else value

    def __iter__(self) -> Iterator[str]:
        return iter(self._tree)

    def __len__(self) -> int:
        return len(self._tree)

    def __repr__(self) -> str:
        return f"Metrics({self._tree!r})"


@dataclass(frozen=True)
class Event:
    t_s: float  # the bench's time, s from the start of the run
    text: str  # a phase change, a board text ("board: ..."), a failsafe, as the recording's events channel has it


@dataclass(frozen=True)
class HilRun:
    """One flight: what flew, how it ended, and where it left its files."""

    scenario: Scenario  # as flown, overrides applied
    board: str  # the board's spec
    autopilot: str  # what flew on it: the emulator's controller, or PX4's own
    exit_code: int
    reason: str
    failures: list[str]  # the expectations not met, one line each
    run_dir: Path
    summary: str
    metrics: Metrics
    events: list[Event]
    report: Path | None  # report.html, when written

    @property
    def passed(self) -> bool:
        return self.exit_code == Exit.OK

    @cached_property
    def flight(self) -> Flight:
        """The whole recording as arrays, every phase (NoFlightData for a run that never reached its mission)."""
        from hil.reports.rundata import load_flight

        return load_flight(self.run_dir)

    @cached_property
    def mission(self) -> RunData:
        """The mission phase: position, reference, attitude, the board's commands and estimates on the mission clock."""
        from hil.reports.rundata import load_run

        return load_run(self.run_dir)

    def board_texts(self, last: int = BOARD_TEXTS) -> list[str]:
        """The board's last STATUSTEXTs of the run, a text repeated in a row given once with its count."""
        texts = [e.text.removeprefix("board: ") for e in self.events if e.text.startswith("board: ")]
        runs = [(text, len(list(group))) for text, group in groupby(texts)]
        return [text if count == 1 else f"{text} ({count} times)" for text, count in runs][-last:]


def _files(run: HilRun) -> list[str]:
    lines = [f"run directory: {run.run_dir}"]
    if run.report is not None:
        lines.append(f"report: {run.report}")
    return lines


def failure_text(run: HilRun) -> str:
    """Why a flight failed: the expectations it missed, or what went wrong in flight."""
    return "\n".join([f"{run.scenario.name} on {run.board} ({run.autopilot}): FAIL", f"  the run: {run.reason}",
                      *(f"  expectation not met: {failure}" for failure in run.failures), *_files(run)])


def error_text(run: HilRun) -> str:
    """Why a run gave no verdict on the flight (exit 2, 3, 4): the reason, the board's last texts, its log."""
    lines = [f"{run.scenario.name} on {run.board}: exit {run.exit_code} ({Exit(run.exit_code).name}): {run.reason}"]
    texts = run.board_texts()
    if texts:
        lines.append("the board's last texts: " + " | ".join(texts))
    lines += [f"board log: {run.run_dir / name}" for name in BOARD_LOGS if (run.run_dir / name).is_file()]
    return "\n".join([*lines, *_files(run)])


def junit_properties(run: HilRun) -> list[tuple[str, str]]:
    """What a CI's test tab shows beside the verdict, named as in metrics.json; strings, as pytest-xdist sends a
    worker's reports as plain data."""
    properties: list[tuple[str, object]] = [
        ("exit_code", run.exit_code), ("reason", run.reason), ("board", run.board), ("autopilot", run.autopilot),
        ("seed", run.scenario.seed), ("run_dir", run.run_dir)]
    if run.report is not None:
        properties.append(("report", run.report))
    timing = run.metrics.get("timing") or {}
    if timing.get("realtime_factor") is not None:
        properties.append(("timing.realtime_factor", f"{timing['realtime_factor']:.3f}"))
    for group, axes in (("position_error_m", "xyz"), ("attitude_error_deg", ("roll", "pitch", "yaw"))):
        for axis in axes if group in run.metrics else ():
            properties.append((f"{group}.{axis}.max_abs", f"{run.metrics[group][axis]['max_abs']:.6g}"))
    return [(name, str(value)) for name, value in properties]
