"""`hil run`: one scenario from file to run directory, exit code and summary."""

from __future__ import annotations

import io
import shutil
import textwrap
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import zenoh

from firmware_interface.board import BoardError, BoardKind
from firmware_interface.geodesy import LocalFrame
from firmware_interface.link import FrameTap, LinkError, TlogWriter
from hil.boards.connect import (
    BoardHandle,
    open_board,
    px4_parameters,
    start_emulator,
    start_px4_hitl,
    start_px4_sitl,
)
from hil.boards.gcs_relay import DEFAULT_GCS, GcsBridge
from hil.boards.px4 import Px4Build
from hil.exit_codes import (
    EXIT_BAD_INPUT,
    EXIT_BOARD,
    EXIT_DISK_FULL,
    EXIT_EXPECT_FAILED,
    EXIT_INTERNAL,
    EXIT_INTERRUPTED,
    EXIT_OK,
    verdict,
)
from hil.host.stop_signals import stopped_by_signals
from hil.judge.metrics import check_expectations, slip_note
from hil.loop.bench import Bench, Sink
from hil.outputs.disk import filesystem_of, is_no_space
from hil.outputs.foxglove_live import FoxgloveServer
from hil.outputs.foxglove_messages import mission_scene
from hil.outputs.recorder import Recorder, make_run_dir
from hil.outputs.telemetry import TelemetryPublisher, ZenohOptions, close_within, open_session
from hil.scenario.schema import Scenario


@dataclass
class RunOptions:
    port: str | None = None  # None: the built-in emulator on a pty
    mavlink: str | None = None  # PX4 SITL: a separate MAVLink link for commands (e.g. udpout:127.0.0.1:14580)
    realtime: bool = False
    connect_timeout_s: float | None = None  # a board the user attached: how long to wait for it
    baud: int | None = None  # serial rate where --port names none
    px4: Px4Build | None = None  # the bench starts PX4 SITL from this build (lockstep)
    px4_hitl: Px4Build | None = None  # the bench starts PX4's HITL code path from this build on a pty
    runs_root: Path = Path("runs")
    keep_failed: bool = False  # keep the run directory of an attempt that never reached a board
    watchdog_s: float = 1.0
    telemetry: ZenohOptions | None = field(default_factory=ZenohOptions)  # None: no telemetry
    telemetry_rates_hz: dict[str, float] = field(default_factory=dict)
    gcs: list[str] | None = None  # ground-station endpoints; None: QGC's default where the bench holds the port
    foxglove: str | None = None  # HOST:PORT of a live Foxglove WebSocket server; None: none


@dataclass
class RunOutcome:
    exit_code: int
    reason: str
    run_dir: Path
    metrics: dict[str, Any]
    failures: list[str]
    summary: str
    kept: bool = True  # False: the board never connected and the run directory was removed


def _board_label(options: RunOptions) -> str:
    if options.px4 is not None:
        return f"PX4 SITL from {options.px4.root}"
    if options.px4_hitl is not None:
        return f"PX4 HITL rehearsal from {options.px4_hitl.root}"
    return "emulator" if options.port is None else options.port


def _board_kind(options: RunOptions) -> str:
    """What flies: the emulator, PX4 SITL, PX4's HITL rehearsal, or a board the user attached."""
    if options.px4 is not None:
        return "px4_sitl"
    if options.px4_hitl is not None:
        return "px4_hitl"
    return "emulator" if options.port is None else "attached"


def gcs_endpoints(options: RunOptions, kind: BoardKind) -> list[str]:
    """Where the board's traffic is relayed: QGC's default for a board whose port the bench holds (serial,
    HITL rehearsal, emulator); none for PX4 SITL, whose own GCS port 18570 -> 14550 QGC uses directly."""
    if options.gcs is not None:
        return options.gcs
    return [] if kind is BoardKind.SITL else [DEFAULT_GCS]


def attach_board(scenario: Scenario, options: RunOptions, run_dir: Path, tap: FrameTap | None = None) -> BoardHandle:
    """Start or connect the board the options name; returns once it has spoken. `tap` sees every frame."""
    if options.px4 is not None:
        handle = start_px4_sitl(options.px4, run_dir, options.watchdog_s, tap)
        handle.params = px4_parameters(scenario)
        return handle
    if options.px4_hitl is not None:
        handle = start_px4_hitl(options.px4_hitl, run_dir, options.watchdog_s, tap)
        handle.params = px4_parameters(scenario)
        return handle
    if options.port is None:
        return start_emulator(scenario, run_dir, options.watchdog_s, tap)
    return open_board(options.port, options.mavlink, options.watchdog_s, options.connect_timeout_s, tap, options.baud)


@dataclass
class _RunState:
    """What the run has reached, for the summary whatever ends it."""

    reason: str = "not started"
    code: int = EXIT_BOARD
    metrics: dict[str, Any] = field(default_factory=dict)
    failures: list[str] = field(default_factory=list)
    board_text: str = "not connected"
    final_t_us: int = 0
    internal_error: str | None = None  # a traceback, written to bench.log


def run_scenario(scenario: Scenario, options: RunOptions, sinks: list[Sink] | None = None,
                 progress: Any = None) -> RunOutcome:
    with stopped_by_signals():
        return _run(scenario, options, sinks, progress)


def _no_room(runs_root: Path, run_dir: Path) -> RunOutcome:
    """The outcome of a run whose directory could not even be set up for lack of space: nothing flew."""
    shutil.rmtree(run_dir, ignore_errors=True)
    reason = f"disk full: no space left on {filesystem_of(runs_root)} for a run directory; nothing was started"
    return RunOutcome(EXIT_DISK_FULL, reason, run_dir, {}, [], f"result: ABORTED (exit {EXIT_DISK_FULL:d})\n"
                      f"ended: {reason}\n", kept=False)


def _run(scenario: Scenario, options: RunOptions, sinks: list[Sink] | None, progress: Any) -> RunOutcome:
    try:
        run_dir = make_run_dir(options.runs_root, scenario.name)
    except OSError as exc:
        if not is_no_space(exc):
            raise
        return _no_room(options.runs_root, options.runs_root)
    meta = {"scenario": scenario.name, "seed": scenario.seed, "rate_hz": scenario.rate_hz,
            "board": _board_label(options), "board_kind": _board_kind(options), "command_link": options.mavlink,
            "pacing": "realtime" if options.realtime else "lockstep (realtime for a serial board)"}
    resolved = scenario.model_dump(mode="json")
    home = scenario.home
    local_frame = home.frame
    try:
        recorder = Recorder(run_dir, resolved, meta, local_frame, scene=lambda t_ns: mission_scene(scenario, t_ns))
    except OSError as exc:
        if not is_no_space(exc):
            raise
        return _no_room(options.runs_root, run_dir)
    state = _RunState()
    flight_code = (f"emulator, controller {scenario.board.controller}"
                   if options.port is None and options.px4 is None and options.px4_hitl is None
                   else "the board's own (PX4)")
    parts = _RunParts(tlog=TlogWriter(run_dir / "link.tlog"))
    try:
        flight_code = _fly(scenario, options, run_dir, recorder, local_frame, meta, resolved, sinks, progress, state,
                           parts) or flight_code
    except KeyboardInterrupt as exc:
        state.reason, state.code = f"interrupted ({exc.args[0] if exc.args else 'Ctrl-C'})", EXIT_INTERRUPTED
    except Exception as exc:
        if is_no_space(exc):  # a write no watch guards: the end is the same
            recorder.disk.failed(Path(exc.filename).name if exc.filename else "the run directory")  # type: ignore[attr-defined]
            state.reason, state.code = recorder.disk.reason(), EXIT_DISK_FULL
        else:
            state.internal_error = traceback.format_exc()
            state.reason, state.code = f"internal error: {type(exc).__name__}: {exc}", EXIT_INTERNAL
    finally:
        summary = _close(scenario, run_dir, recorder, parts, state, flight_code)
    never_connected = parts.handle is None and state.code in (EXIT_BOARD, EXIT_BAD_INPUT, EXIT_INTERRUPTED)
    if never_connected and not options.keep_failed:  # nothing flew: no directory to clutter runs/
        shutil.rmtree(run_dir, ignore_errors=True)
    return RunOutcome(state.code, state.reason, run_dir, state.metrics, state.failures, summary,
                      kept=not never_connected or options.keep_failed)


@dataclass
class _RunParts:
    """What the run opened, closed in `_close` whatever happened."""

    tlog: TlogWriter
    handle: BoardHandle | None = None
    session: Any = None
    publisher: TelemetryPublisher | None = None
    live: FoxgloveServer | None = None


def _fly(scenario: Scenario, options: RunOptions, run_dir: Path, recorder: Recorder, local_frame: LocalFrame,
         meta: dict[str, Any], resolved: dict[str, Any], sinks: list[Sink] | None, progress: Any,
         state: _RunState, parts: _RunParts) -> str | None:
    """Connect, fly, judge; fills `state`. Returns the flight code's description once a board spoke."""
    if options.foxglove is not None:
        try:
            parts.live = FoxgloveServer(options.foxglove, local_frame, recorder.start_ns,
                                        mission_scene(scenario, recorder.start_ns),
                                        {**scenario.telemetry.rates_hz, **options.telemetry_rates_hz})
        except RuntimeError as exc:  # foxglove-sdk's FoxgloveError: the address is taken or invalid
            state.reason, state.code = f"--foxglove {options.foxglove}: {exc}", EXIT_BAD_INPUT
            return None
    if options.telemetry is not None:  # before the board: a Zenoh mistake must not start one
        try:
            parts.session = open_session(options.telemetry)
        except zenoh.ZError as exc:
            state.reason, state.code = f"Zenoh: {str(exc).split(' at /')[0]}", EXIT_BAD_INPUT
            return None
        parts.publisher = TelemetryPublisher(parts.session, run_dir.name,
                                             {"run_id": run_dir.name, **meta, "scenario": resolved},
                                             {**scenario.telemetry.rates_hz, **options.telemetry_rates_hz},
                                             lambda: parts.handle.session.link.counters)  # type: ignore[union-attr]
    try:
        parts.handle = handle = attach_board(scenario, options, run_dir, recorder.disk.guard(parts.tlog, "link.tlog"))
    except (BoardError, LinkError) as exc:
        state.reason, state.code = f"board/link failure: {exc}", EXIT_BOARD
        return None
    state.board_text = handle.description
    endpoints = gcs_endpoints(options, handle.kind)
    if endpoints:
        handle.relay_to(GcsBridge(endpoints))
        state.board_text += f"; ground station relay to {', '.join(endpoints)}"
    else:  # no ground station reads the command link through the bench: the board need not stream what we skip
        handle.commands.stop_unread_streams = handle.kind is not BoardKind.EMULATOR
    all_sinks: list[Sink] = [recorder.record, *(sinks or [])]
    events: list[Callable[[int, str], None]] = [recorder.event]
    if parts.publisher is not None:
        all_sinks.append(parts.publisher)
        events.append(parts.publisher.event)
    if parts.live is not None:
        all_sinks.append(parts.live)
        events.append(parts.live.event)
    bench = Bench(scenario, handle, options.realtime, all_sinks, progress,
                  on_event=lambda t_us, text: _emit_all(events, t_us, text))
    recorder.background = bench.realtime  # a chunk's compression must not delay a paced step
    result = bench.run()
    state.reason, state.code, state.metrics = result.reason, result.exit_code, result.metrics
    state.internal_error, state.final_t_us = bench.internal_error, bench.t_us
    if state.code == EXIT_BOARD and (note := handle.exit_note()):
        state.reason = f"{state.reason}; {note}"
    if state.code == EXIT_OK:
        px4 = handle.kind is not BoardKind.EMULATOR
        state.failures = check_expectations(scenario.expect.for_board(px4) if scenario.expect else None, state.metrics)
        state.code = EXIT_EXPECT_FAILED if state.failures else EXIT_OK
    return handle.flight_code


def _emit_all(events: list[Callable[[int, str], None]], t_us: int, text: str) -> None:
    """A run event to the recording, Zenoh and the live view."""
    for emit in events:
        emit(t_us, text)


ZENOH_CLOSE_S = 1.0  # the longest a stalled subscriber may hold up the end of a run


def _close_telemetry(parts: _RunParts, final_t_us: int, metrics: dict[str, Any], summary: str) -> None:
    """The summary to Zenoh subscribers, then undeclare and close, in bounded time: a stopped or stalled
    subscriber can hold a put or the session's close for many seconds, the bench does not wait for it."""
    def finish() -> None:
        if parts.publisher is not None:
            parts.publisher.summary(final_t_us, metrics, summary)
            parts.publisher.close()
        parts.session.close()

    close_within(finish, ZENOH_CLOSE_S)


def _close(scenario: Scenario, run_dir: Path, recorder: Recorder, parts: _RunParts, state: _RunState,
           flight_code: str) -> str:
    """Stop the board, close every file and session; the summary and metrics say how the run ended."""
    if state.internal_error is not None:
        recorder.disk.release()  # the traceback goes in the reserve, whatever the error was
        recorder.disk.attempt("bench.log", lambda: (run_dir / "bench.log").write_text(state.internal_error or ""))
        state.reason += f" (a bench bug: traceback in {run_dir / 'bench.log'})"
    if parts.handle is not None:
        parts.handle.close()
    recorder.disk.attempt("link.tlog", parts.tlog.close)
    summary = format_summary(scenario, state.board_text, flight_code, state.reason, state.code, state.metrics,
                             state.failures)
    full_metrics = {"exit_code": state.code, "reason": state.reason, "expectations_failed": state.failures,
                    **state.metrics}
    recorder.finish(full_metrics, summary)
    if parts.session is not None:
        _close_telemetry(parts, state.final_t_us, full_metrics, summary)
    if parts.live is not None:
        parts.live.close()
    return summary


SUMMARY_WIDTH = 100  # columns: the summary fits a terminal and the file reads the same


def _error_table(metrics: dict[str, Any]) -> str:
    """The per-axis error figures as a table: [min, max], RMS and max |e| per axis and quantity."""
    from rich.console import Console
    from rich.table import Table

    rows = [("position - reference (m)", "position_error_m", 3),
            ("board estimate - truth (m)", "board_estimate_error_m", 3),
            ("board attitude - truth (deg)", "board_attitude_estimate_error_deg", 2),
            ("attitude - commanded (deg)", "attitude_error_deg", 2)]
    present = [(label, metrics[key], digits) for label, key, digits in rows if metrics.get(key)]
    if not present:
        return ""
    table = Table(box=None, pad_edge=False, show_edge=False, title_justify="left",
                  title=f"mission errors (tracking after {metrics.get('settle_s', 0):g} s): \\[min, max] rms")
    table.add_column("", no_wrap=True)
    for axis in ("x / roll", "y / pitch", "z / yaw"):
        table.add_column(axis, justify="right", overflow="fold")
    for label, stats, digits in present:
        cells = [f"[{s['min']:+.{digits}f}, {s['max']:+.{digits}f}] {s['rms']:.{digits}f}" if s else "–"
                 for s in stats.values()]
        table.add_row(label, *cells)
    console = Console(width=SUMMARY_WIDTH, file=io.StringIO(), color_system=None, force_terminal=False)
    console.print(table)
    text = console.file.getvalue()  # type: ignore[attr-defined]
    return "\n".join(line.rstrip() for line in text.splitlines())


def format_summary(scenario: Scenario, board: str, flight_code: str, reason: str, code: int,
                   metrics: dict[str, Any], failures: list[str]) -> str:
    result = verdict(code)
    lines = [f"scenario: {scenario.name} (seed {scenario.seed}, {scenario.rate_hz:g} Hz, {scenario.duration_s:g} s)",
             f"board: {board}", f"flight code: {flight_code}",
             f"result: {result} (exit {code})", f"ended: {reason}"]
    if "phase_reached" in metrics:
        lines.append(f"phase reached: {metrics['phase_reached']}")
    table = _error_table(metrics)
    if table:
        lines += table.rstrip("\n").splitlines()
    for window in metrics.get("board_estimates", {}).get("mass_estimate_windows", []):
        lines.append(f"mass estimate at {window['end_s']:.1f} s: {window['m_hat_kg']:.3f} kg "
                     f"(true {window['true_mass_kg']:.2f} kg, {window['error_pct']:+.1f} %)")
    timing = metrics.get("timing")
    if timing:
        rtf = timing.get("realtime_factor")
        lines.append(f"timing: {timing['sim_s']:.2f} s simulated in {timing['wall_s']:.2f} s wall"
                     + (f", real-time factor {rtf:.2f}" if rtf else ""))
        if timing.get("round_trip_us"):
            rt = timing["round_trip_us"]
            lines.append(f"sensor -> actuator round trip: p50 {rt['p50']:.0f} us, p99 {rt['p99']:.0f} us")
        if timing.get("board_cpu_us_per_step") is not None:
            lines.append(f"board's own CPU: {timing['board_cpu_us_per_step']:.0f} us per step")
        if "period_jitter_us" in timing:
            j = timing["period_jitter_us"]
            lines.append(f"step period jitter: p50 {j['p50']:.0f} us, p99 {j['p99']:.0f} us, max {j['max']:.0f} us, "
                         f"late steps {timing['late_steps']}{slip_note(timing)}")
    link = metrics.get("link")
    if link:
        errors = {k: v for k, v in link.items()
                  if k not in ("frames_in", "frames_out", "bytes_in", "bytes_out", "passed_through") and v}
        lines.append(f"link: {link.get('frames_in', 0)} frames in, {link.get('frames_out', 0)} out; "
                     f"errors: {errors or 'none'}")
    if scenario.expect is not None and reason == "completed":  # checked only for a flight that completed
        lines.append("expectations: " + ("met" if not failures else "NOT met"))
        lines += [f"  - {f}" for f in failures]
    return "\n".join(textwrap.fill(line, SUMMARY_WIDTH, subsequent_indent="    ", break_on_hyphens=False)
                     if len(line) > SUMMARY_WIDTH else line for line in lines) + "\n"
