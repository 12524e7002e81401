"""`hil run`: one scenario from file to run directory, exit code and summary."""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from firmware_interface.board import BoardError, BoardKind
from firmware_interface.link import FrameTap, LinkError, TlogWriter
from hil.bench import (
    EXIT_BOARD,
    EXIT_EXPECT_FAILED,
    EXIT_INTERRUPTED,
    EXIT_OK,
    Bench,
    Sink,
)
from hil.connect import (
    BoardHandle,
    open_board,
    px4_parameters,
    start_emulator,
    start_px4_hitl,
    start_px4_sitl,
)
from hil.gcs import DEFAULT_GCS, GcsBridge
from hil.metrics import check_expectations
from hil.px4 import Px4Build
from hil.recorder import Recorder, make_run_dir
from hil.scenario.schema import Scenario
from hil.telemetry import TelemetryPublisher, ZenohOptions, open_session


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
    watchdog_s: float = 1.0
    telemetry: ZenohOptions | None = field(default_factory=ZenohOptions)  # None: no telemetry
    telemetry_rates_hz: dict[str, float] = field(default_factory=dict)
    gcs: list[str] | None = None  # ground-station endpoints; None: QGC's default where the bench holds the port


@dataclass
class RunOutcome:
    exit_code: int
    reason: str
    run_dir: Path
    metrics: dict[str, Any]
    failures: list[str]
    summary: str


def _board_label(options: RunOptions) -> str:
    if options.px4 is not None:
        return f"PX4 SITL from {options.px4.root}"
    if options.px4_hitl is not None:
        return f"PX4 HITL rehearsal from {options.px4_hitl.root}"
    return "emulator" if options.port is None else options.port


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


@contextmanager
def _sigint_deferred() -> Iterator[None]:
    """Closing PX4 and the recording is not interrupted by a second Ctrl-C (it would orphan PX4)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def run_scenario(scenario: Scenario, options: RunOptions, sinks: list[Sink] | None = None,
                 progress: Any = None) -> RunOutcome:
    run_dir = make_run_dir(options.runs_root, scenario.name)
    meta = {"scenario": scenario.name, "seed": scenario.seed, "rate_hz": scenario.rate_hz,
            "board": _board_label(options), "command_link": options.mavlink,
            "pacing": "realtime" if options.realtime else "lockstep (realtime for a serial board)"}
    resolved = scenario.model_dump(mode="json")
    recorder = Recorder(run_dir, resolved, meta)
    handle: BoardHandle | None = None
    session, publisher = None, None
    final_t_us = 0
    metrics: dict[str, Any] = {}
    failures: list[str] = []
    board_text = "not connected"
    flight_code = (f"emulator, controller {scenario.board.controller}"
                   if options.port is None and options.px4 is None and options.px4_hitl is None
                   else "the board's own (PX4)")
    reason, code = "not started", EXIT_BOARD
    tlog = TlogWriter(run_dir / "link.tlog")
    try:
        try:
            handle = attach_board(scenario, options, run_dir, tlog)
            board_text, flight_code = handle.description, handle.flight_code
            endpoints = gcs_endpoints(options, handle.kind)
            if endpoints:
                handle.relay_to(GcsBridge(endpoints))
                board_text += f"; ground station relay to {', '.join(endpoints)}"
        except (BoardError, LinkError) as exc:
            reason, code = f"board/link failure: {exc}", EXIT_BOARD
        except KeyboardInterrupt:
            reason, code = "interrupted (Ctrl-C) while connecting", EXIT_INTERRUPTED
        else:
            all_sinks: list[Sink] = [recorder.record, *(sinks or [])]
            events = [recorder.event]
            if options.telemetry is not None:
                session = open_session(options.telemetry)
                publisher = TelemetryPublisher(session, run_dir.name, {"run_id": run_dir.name, **meta,
                                                                        "scenario": resolved},
                                               {**scenario.telemetry.rates_hz, **options.telemetry_rates_hz},
                                               lambda: handle.session.link.counters)  # type: ignore[union-attr]
                all_sinks.append(publisher)
                events.append(publisher.event)
            bench = Bench(scenario, handle, options.realtime, all_sinks, progress,
                          on_event=lambda t_us, text: [emit(t_us, text) for emit in events])
            result = bench.run()
            reason, code, metrics = result.reason, result.exit_code, result.metrics
            if code == EXIT_BOARD and (note := handle.exit_note()):
                reason = f"{reason}; {note}"
            final_t_us = bench.t_us
            if code == EXIT_OK:
                px4 = handle.kind is not BoardKind.EMULATOR
                failures = check_expectations(scenario.expect.for_board(px4) if scenario.expect else None, metrics)
                code = EXIT_EXPECT_FAILED if failures else EXIT_OK
    finally:
        with _sigint_deferred():
            if handle is not None:
                handle.close()
            tlog.close()
            summary = format_summary(scenario, board_text, flight_code, reason, code, metrics, failures)
            full_metrics = {"exit_code": code, "reason": reason, "expectations_failed": failures, **metrics}
            recorder.finish(full_metrics, summary)
            if publisher is not None:
                publisher.summary(final_t_us, full_metrics, summary)
                publisher.close()
            if session is not None:
                session.close()
    return RunOutcome(code, reason, run_dir, metrics, failures, summary)


def _axis_line(label: str, stats: dict[str, dict[str, float]], unit: str) -> str:
    parts = [f"{axis}: [{s['min']:+.3f}, {s['max']:+.3f}] rms {s['rms']:.3f} max|e| {s['max_abs']:.3f}"
             for axis, s in stats.items() if s]
    return f"{label} ({unit}): " + "; ".join(parts)


def format_summary(scenario: Scenario, board: str, flight_code: str, reason: str, code: int,
                   metrics: dict[str, Any], failures: list[str]) -> str:
    verdict = {EXIT_OK: "PASS", EXIT_EXPECT_FAILED: "FAIL"}.get(code, "ABORTED")
    lines = [f"scenario: {scenario.name} (seed {scenario.seed}, {scenario.rate_hz:g} Hz, {scenario.duration_s:g} s)",
             f"board: {board}", f"flight code: {flight_code}",
             f"result: {verdict} (exit {code})", f"ended: {reason}"]
    if "phase_reached" in metrics:
        lines.append(f"phase reached: {metrics['phase_reached']}")
    if "position_error_m" in metrics:
        lines.append(_axis_line(f"position error after {metrics['settle_s']:g} s", metrics["position_error_m"], "m"))
    if "board_estimate_error_m" in metrics:
        lines.append(_axis_line("board's position estimate - truth", metrics["board_estimate_error_m"], "m"))
    if "board_attitude_estimate_error_deg" in metrics:
        lines.append(_axis_line("board's attitude estimate - truth", metrics["board_attitude_estimate_error_deg"],
                                "deg"))
    if "attitude_error_deg" in metrics:
        lines.append(_axis_line("attitude error vs commanded", metrics["attitude_error_deg"], "deg"))
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
        if "period_jitter_us" in timing:
            j = timing["period_jitter_us"]
            lines.append(f"step period jitter: p50 {j['p50']:.0f} us, p99 {j['p99']:.0f} us, max {j['max']:.0f} us, "
                         f"late steps {timing['late_steps']}")
    link = metrics.get("link")
    if link:
        errors = {k: v for k, v in link.items()
                  if k not in ("frames_in", "frames_out", "bytes_in", "bytes_out", "passed_through") and v}
        lines.append(f"link: {link.get('frames_in', 0)} frames in, {link.get('frames_out', 0)} out; "
                     f"errors: {errors or 'none'}")
    if scenario.expect is not None and code in (EXIT_OK, EXIT_EXPECT_FAILED):
        lines.append("expectations: " + ("met" if not failures else "NOT met"))
        lines += [f"  - {f}" for f in failures]
    return "\n".join(lines) + "\n"
