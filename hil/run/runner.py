"""`hil run`: one scenario from file to run directory, exit code and summary.

The run opens its outputs (before any board starts, so that a bad address is bad input), attaches the board, builds
the world and the pilot, flies the loop, judges the result, and closes everything it opened whatever ended it.
"""

from __future__ import annotations

import shutil
import time
import traceback
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from firmware_interface.board import BoardError
from firmware_interface.link import LinkError, TlogWriter
from firmware_interface.link.dialect import message_name
from hil.boards.emulator import EmulatorTarget
from hil.boards.gcs_relay import GcsBridge
from hil.boards.handle import BoardHandle
from hil.boards.target import BoardPolicy, BoardTarget, LinkSettings
from hil.exit_codes import EXIT_BAD_INPUT, EXIT_BOARD, EXIT_EXPECT_FAILED, EXIT_INTERNAL, EXIT_INTERRUPTED, EXIT_OK
from hil.host.stop_signals import stopped_by_signals
from hil.judge.metrics import MetricsCollector, check_expectations
from hil.loop.sink import Outcome, Sink
from hil.loop.stepper import Progress, Stepper
from hil.outputs.context import OutputContext, OutputError
from hil.outputs.recorder import make_run_dir
from hil.outputs.registry import OUTPUTS
from hil.outputs.zenoh_session import ZenohOptions
from hil.pilots.registry import make_pilot
from hil.run.summary import format_summary
from hil.run.world import build_world, reversible_rotors, step_us, vehicle_parameters
from hil.scenario.mission import MissionPlan
from hil.scenario.schema import Scenario


@dataclass
class RunOptions:
    board: BoardTarget = field(default_factory=EmulatorTarget)  # what flies (hil.boards.registry names them)
    realtime: bool = False  # pace the run on the wall clock even when the board would run in lockstep
    runs_root: Path = Path("runs")
    keep_failed: bool = False  # keep the run directory of an attempt that never reached a board
    watchdog_s: float = 1.0
    telemetry: ZenohOptions | None = field(default_factory=ZenohOptions)  # None: no telemetry
    telemetry_rates_hz: dict[str, float] = field(default_factory=dict)
    gcs: list[str] | None = None  # ground-station endpoints; None: the board kind's default
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


@dataclass
class _RunState:
    """What the run has reached, for the summary whatever ends it."""

    flight_code: str
    reason: str = "not started"
    code: int = EXIT_BOARD
    metrics: dict[str, Any] = field(default_factory=dict)
    failures: list[str] = field(default_factory=list)
    board_text: str = "not connected"
    final_t_us: int = 0
    internal_error: str | None = None  # a traceback, written to bench.log
    handle: BoardHandle | None = None
    summary: str = ""


def run_scenario(scenario: Scenario, options: RunOptions, sinks: list[Sink] | None = None,
                 progress: Progress | None = None) -> RunOutcome:
    """Fly `scenario` as `options` say; `sinks` take every frame and event besides the run's own outputs."""
    with stopped_by_signals():
        return _run(scenario, options, sinks or [], progress)


def _run(scenario: Scenario, options: RunOptions, extra_sinks: list[Sink], progress: Progress | None) -> RunOutcome:
    policy = options.board.policy(scenario)
    paced = options.realtime or policy.wall_clock or bool(scenario.faults.link)
    run_dir = make_run_dir(options.runs_root, scenario.name)
    meta = {"scenario": scenario.name, "seed": scenario.seed, "rate_hz": scenario.rate_hz,
            "board": options.board.label, "board_kind": policy.kind,
            "pacing": "realtime" if paced else "lockstep"}
    state = _RunState(policy.flight_code)
    sinks: list[Sink] = []
    with ExitStack() as stack:
        tlog = TlogWriter(run_dir / "link.tlog")
        stack.callback(lambda: _close(scenario, run_dir, sinks, state))
        stack.callback(tlog.close)
        try:
            context = OutputContext(run_dir, scenario, meta, time.time_ns(), paced,
                                    {**scenario.telemetry.rates_hz, **options.telemetry_rates_hz},
                                    lambda: state.handle.session.link.counters if state.handle else {},
                                    options.telemetry, options.foxglove)
            sinks += [sink for open_output in OUTPUTS if (sink := open_output(context)) is not None]
            _fly(scenario, options, policy, paced, run_dir, [*sinks, *extra_sinks], progress, state, stack, tlog)
        except OutputError as exc:
            state.reason, state.code = str(exc), EXIT_BAD_INPUT
        except KeyboardInterrupt as exc:
            state.reason, state.code = f"interrupted ({exc.args[0] if exc.args else 'Ctrl-C'})", EXIT_INTERRUPTED
        except Exception as exc:
            state.internal_error = traceback.format_exc()
            state.reason, state.code = f"internal error: {type(exc).__name__}: {exc}", EXIT_INTERNAL
    never_connected = state.handle is None and state.code in (EXIT_BOARD, EXIT_BAD_INPUT, EXIT_INTERRUPTED)
    if never_connected and not options.keep_failed:  # nothing flew: no directory to clutter runs/
        shutil.rmtree(run_dir, ignore_errors=True)
    return RunOutcome(state.code, state.reason, run_dir, state.metrics, state.failures, state.summary,
                      kept=not never_connected or options.keep_failed)


def _fly(scenario: Scenario, options: RunOptions, policy: BoardPolicy, paced: bool, run_dir: Path, sinks: list[Sink],
         progress: Progress | None, state: _RunState, stack: ExitStack, tlog: TlogWriter) -> None:
    """Attach, fly, judge; fills `state`."""
    plan = MissionPlan.build(scenario)
    parameters = vehicle_parameters(scenario, plan)
    settings = LinkSettings(options.watchdog_s, tlog, reversible_rotors(parameters))
    try:
        state.handle = handle = options.board.attach(scenario, run_dir, settings)
    except (BoardError, LinkError) as exc:
        state.reason, state.code = f"board/link failure: {exc}", EXIT_BOARD
        return
    stack.callback(handle.close)  # before the outputs close: the board is stopped first
    state.board_text = handle.description + _relay(handle, policy, options.gcs)
    world = build_world(scenario, handle, parameters)
    stack.callback(world.plant.close)
    metrics = MetricsCollector(scenario.expect.settle_s if scenario.expect else 5.0)
    pilot = make_pilot(scenario, plan, step_us(scenario))
    stepper = Stepper(world, handle, pilot, [metrics, *sinks], step_us(scenario), paced, policy.ground_truth, progress)
    result = stepper.run()
    state.reason, state.code, state.internal_error = result.reason, result.exit_code, result.internal_error
    state.final_t_us = stepper.t_us
    state.metrics = {**metrics.compute(), "timing": stepper.timing.figures(paced),
                     "link": handle.session.link.counters, **pilot.summary(), **_link_figures(stepper, handle)}
    if state.code == EXIT_BOARD and (note := handle.exit_note()):
        state.reason = f"{state.reason}; {note}"
    if state.code == EXIT_OK:
        state.failures = check_expectations(scenario.expect.for_board(policy.px4) if scenario.expect else None,
                                            state.metrics)
        state.code = EXIT_EXPECT_FAILED if state.failures else EXIT_OK


def _relay(handle: BoardHandle, policy: BoardPolicy, endpoints: list[str] | None) -> str:
    """Relay the board's traffic to ground stations (the kind's default when the user names none); with none, a
    board that streams much is asked to stop what nobody reads. Returns the note for the summary's board line."""
    chosen = list(policy.default_gcs) if endpoints is None else endpoints
    if chosen:
        handle.relay_to(GcsBridge(chosen))
        return f"; ground station relay to {', '.join(chosen)}"
    handle.commands.stop_unread_streams = policy.stops_unread_streams
    return ""


def _link_figures(stepper: Stepper, handle: BoardHandle) -> dict[str, Any]:
    """Injected link faults (with the board's failsafe texts), the ground-station relay, the streams stopped."""
    figures: dict[str, Any] = {}
    if stepper.world.link_faults:
        injected: dict[str, int] = {}
        for faults in stepper.world.link_faults:
            for key, count in faults.counts.items():
                injected[key] = injected.get(key, 0) + count
        figures["link_faults"] = {"injected": injected, "board_failsafe": [{"t_s": t, "text": text}
                                                                          for t, text in stepper.failsafe_texts]}
    if handle.gcs is not None:
        figures["gcs"] = handle.gcs.counters()
    if handle.commands.streams_stopped:
        figures["board_streams_stopped"] = [message_name(i) for i in handle.commands.streams_stopped]
    return figures


def _close(scenario: Scenario, run_dir: Path, sinks: list[Sink], state: _RunState) -> None:
    """The summary and metrics say how the run ended; every sink closes with them, in the order they opened."""
    if state.internal_error is not None:
        (run_dir / "bench.log").write_text(state.internal_error)
        state.reason += f" (a bench bug: traceback in {run_dir / 'bench.log'})"
    state.summary = format_summary(scenario, state.board_text, state.flight_code, state.reason, state.code,
                                   state.metrics, state.failures)
    outcome = Outcome(state.final_t_us, {"exit_code": state.code, "reason": state.reason,
                                         "expectations_failed": state.failures, **state.metrics}, state.summary)
    for sink in sinks:
        sink.close(outcome)
