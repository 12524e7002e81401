"""`hil run`: one scenario from file to run directory, exit code and summary.

The run opens its plant and checks it at rest (a plant that fails is bad input: MappingError or PlantError, raised
before anything else starts), opens its outputs (before any board starts, so that a bad address is bad input),
attaches the board, builds the world and the pilot, flies the loop, judges the result, and closes everything it
opened whatever ended it.
"""

from __future__ import annotations

import gc
import shutil
import time
import traceback
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from firmware_interface.board import BoardError
from firmware_interface.link import FrameTap, LinkError, TlogWriter
from firmware_interface.link.dialect import message_name
from hil.boards.emulator import EmulatorTarget
from hil.boards.gcs_relay import GcsBridge, default_endpoints
from hil.boards.handle import BoardHandle
from hil.boards.target import BoardPolicy, BoardTarget, LinkSettings
from hil.exit_codes import (
    EXIT_BAD_INPUT,
    EXIT_BOARD,
    EXIT_DISK_FULL,
    EXIT_EXPECT_FAILED,
    EXIT_INTERNAL,
    EXIT_INTERRUPTED,
    EXIT_OK,
)
from hil.host.beside import BLOCKED_S, Beside, beside
from hil.host.idle_cpus import idle_cpus_polling
from hil.host.stop_signals import stopped_by_signals
from hil.judge.behaviour import behaviour_judge
from hil.judge.metrics import MetricsCollector, check_expectations
from hil.loop.sink import FrameSink, Outcome, Sink
from hil.loop.step_frames import freeze, warm_up
from hil.loop.stepper import Progress, Stepper
from hil.outputs.context import OutputContext, OutputError
from hil.outputs.disk import DiskWatch, filesystem_of, is_no_space
from hil.outputs.recorder import make_run_dir
from hil.outputs.registry import OUTPUTS
from hil.outputs.zenoh_session import ZenohOptions
from hil.pilots.registry import make_pilot
from hil.run.summary import format_summary
from hil.run.world import build_world, open_plant, reversible_rotors, step_us, vehicle_parameters
from hil.scenario.mission import MissionPlan
from hil.scenario.schema import Scenario
from plant_fmu import Plant

# how long a board failure waits for the board's process to be gone, to give its exit as the cause (a killed PX4's
# exit is posted a moment after its sockets reset); a board alive after it costs the failed run this much
DYING_BOARD_S = 1.0


@dataclass
class RunOptions:
    board: BoardTarget = field(default_factory=EmulatorTarget)  # what flies (hil.boards.registry names them)
    realtime: bool = False  # pace the run on the wall clock even when the board would run in lockstep
    spin_wait: bool = False  # poll for the board's lockstep replies before sleeping (a machine with a core to spare)
    runs_root: Path = Path("runs")
    keep_failed: bool = False  # keep the run directory of an attempt that never reached a board
    watchdog_s: float = 1.0
    telemetry: ZenohOptions | None = field(default_factory=ZenohOptions)  # None: no telemetry
    telemetry_rates_hz: dict[str, float] = field(default_factory=dict)
    gcs: list[str] | None = None  # ground-station endpoints; None: the board kind's default
    foxglove: str | None = None  # HOST:PORT of a live Foxglove WebSocket server; None: none
    speed_factor: float = 1.0  # a lockstep board paced at this many times the wall clock (an outside pilot's runs
    # are paced, at 1 by default: PX4's simulators' convention, PX4_SIM_SPEED_FACTOR)
    idle_cpus_poll: bool = True  # idle CPUs kept polling while a lockstep run flies (False: `--power-save`)


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
class _RunReport:
    """What the run has reached, for the summary whatever ends it."""

    autopilot: str
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
    """Fly `scenario` as `options` say; `sinks` take every frame and event besides the run's own outputs. A plant
    that cannot be opened or fails its check at rest raises MappingError or PlantError, with nothing started."""
    plan = MissionPlan.build(scenario)
    parameters = vehicle_parameters(scenario, plan)
    with stopped_by_signals(), open_plant(scenario, parameters) as plant:
        return _run(_Flight(scenario, plan, parameters, plant), options, sinks or [], progress)


@dataclass(frozen=True)
class _Flight:
    """What flies: the scenario, its flight plan, and the plant opened with its parameters."""

    scenario: Scenario
    plan: MissionPlan
    parameters: dict[str, float]
    plant: Plant


@dataclass
class _Run:
    """One run's fixed parts: what flies, how it is paced, where it writes."""

    flight: _Flight
    options: RunOptions
    policy: BoardPolicy
    paced: bool
    run_dir: Path
    disk: DiskWatch  # the run directory's space: a reserve for the last files, the first write that failed
    report: _RunReport

    @property
    def scenario(self) -> Scenario:
        return self.flight.scenario

    @classmethod
    def prepare(cls, flight: _Flight, options: RunOptions) -> _Run:
        """The run's directory and its disk watch (OSError when there is no room even for them)."""
        scenario = flight.scenario
        policy = options.board.policy(scenario)
        paced = (options.realtime or policy.wall_clock or bool(scenario.faults.link) or options.speed_factor != 1.0
                 or scenario.pilot.type == "external")  # someone on the other side lives in wall-clock time
        run_dir = make_run_dir(options.runs_root, scenario.name)
        try:
            disk = DiskWatch(run_dir)
        except OSError:
            shutil.rmtree(run_dir, ignore_errors=True)
            raise
        return cls(flight, options, policy, paced, run_dir, disk, _RunReport(policy.autopilot))

    @property
    def idle_cpus_not_for(self) -> str | None:
        """Why the run leaves idle CPUs halting (`hil/host/idle_cpus.py`), None when it keeps them polling."""
        if not self.options.idle_cpus_poll:
            return "--power-save"
        return "a paced run: its worst wake-up counts more than its typical one" if self.paced else None

    @property
    def meta(self) -> dict[str, Any]:
        scenario = self.scenario
        return {"scenario": scenario.name, "seed": scenario.seed, "rate_hz": scenario.rate_hz,
                "board": self.options.board.label, "board_kind": self.policy.kind, "pilot": scenario.pilot.type,
                "pacing": "realtime" if self.paced else "lockstep", "speed_factor": self.options.speed_factor}

    def output_context(self) -> OutputContext:
        report = self.report
        return OutputContext(self.run_dir, self.scenario, self.meta, time.time_ns(), self.paced,
                             {**self.scenario.telemetry.rates_hz, **self.options.telemetry_rates_hz},
                             lambda: report.handle.hil_session.link.counters if report.handle else {}, self.disk,
                             self.options.telemetry, self.options.foxglove)

    def attach_and_fly(self, sinks: list[Sink], progress: Progress | None, stack: ExitStack, tlog: FrameTap) -> None:
        """Attach, fly, judge; fills `report`. What it opens is closed by `stack`."""
        scenario, report, flight = self.scenario, self.report, self.flight
        ready_to_step = beside(_prepare_to_step, "prepare-to-step")  # while the board starts
        # a run that ends before its first step (Ctrl-C, SIGTERM, a board that never came) still waits for it, as
        # long as it computes (`Beside.settle`)
        stack.callback(_settled, ready_to_step, report)
        settings = LinkSettings(self.options.watchdog_s, tlog, reversible_rotors(flight.parameters),
                                self.options.speed_factor, flight.plant.rotor_geometry(flight.parameters),
                                ready_to_step, self.options.spin_wait)
        try:
            report.handle = handle = self.options.board.attach(scenario, self.run_dir, settings)
        except (BoardError, LinkError) as exc:
            report.reason, report.code = f"board/link failure: {exc}", EXIT_BOARD
            return
        stack.callback(handle.close)  # before the outputs close: the board is stopped first
        if self.options.spin_wait:
            handle.hil_session.link.spin_wait()
        report.board_text = handle.description + _relay(handle, self.policy, self.options.gcs, scenario.pilot.type)
        world = build_world(scenario, handle, flight.plant)
        metrics = MetricsCollector(scenario.expect.settle_s if scenario.expect else 5.0)
        expect = scenario.expect.for_board(self.policy.px4) if scenario.expect else None
        behaviour = behaviour_judge(scenario, expect)
        pilot = make_pilot(scenario, flight.plan, step_us(scenario))
        ready_to_step()
        freeze()  # here, on the thread that flies (`step_frames.freeze`)
        stepper = Stepper(world, handle, pilot, [metrics, behaviour, *sinks], step_us(scenario), self.paced,
                          self.policy.ground_truth, progress, self.options.speed_factor)
        with idle_cpus_polling(self.idle_cpus_not_for) as idle_cpus:
            result = stepper.run()
        report.reason, report.code, report.internal_error = result.reason, result.exit_code, result.internal_error
        report.final_t_us = stepper.t_us
        timing = {**stepper.timing.figures(self.paced), "idle_cpus": idle_cpus}
        if (starvation := handle.hil_session.starvation) is not None and (waits := starvation.figures()):
            timing["board_cpu_waits"] = waits
        if (dropped := handle.hil_session.watchdog.dropped_replies) is not None and (replies := dropped.figures()):
            timing["lockstep_replies_dropped"] = replies
        report.metrics = {**metrics.compute(), "timing": timing,
                          "link": handle.hil_session.link.counters, **pilot.summary(),
                          "behaviour": behaviour.figures(), **_link_figures(stepper, handle)}
        if report.code == EXIT_BOARD and (note := handle.exit_note(DYING_BOARD_S) or handle.console_note()):
            report.reason = f"{report.reason}; {note}"
        if report.code == EXIT_OK:
            verdicts = behaviour.verdicts(expect)
            report.failures = check_expectations(expect, report.metrics) + [v.line() for v in verdicts if not v.met]
            report.metrics["verdicts"] = [v.as_dict() for v in verdicts]
            for verdict in verdicts:  # in the recording at the time each was decided
                for sink in stepper.sinks:
                    sink.on_event(verdict.decided_t_us, f"expect {'met' if verdict.met else 'NOT met'}: "
                                                        f"{verdict.line()}")
            report.code = EXIT_EXPECT_FAILED if report.failures else EXIT_OK


def _prepare_to_step() -> None:
    """What the first step needs and no board should wait for once it has connected: the compiled step loaded
    (~0.2-0.4 s) and the start-up's garbage collected (a full collection, ~80 ms; the flight's frozen heap then
    collects only the young generations). Measured with PX4 SITL: it waited 240-320 ms for its first sensor frame
    after connecting, and over its 1 s with three flights on two cores; now 3-4 ms."""
    warm_up()
    gc.collect()


def _settled(ready_to_step: Beside, report: _RunReport) -> None:
    """The step's preparation waited for at the run's end; a failure only matters to a run that steps, which has
    raised it. One that stopped computing unfinished is left behind, and the summary says so."""
    if not ready_to_step.settle():
        report.reason += (f"; the compiled step's loading stopped using CPU unfinished: left behind after "
                          f"{BLOCKED_S:g} s")


def _no_room(runs_root: Path) -> RunOutcome:
    """The outcome of a run whose directory could not even be set up for lack of space: nothing flew."""
    reason = f"disk full: no space left on {filesystem_of(runs_root)} for a run directory; nothing was started"
    return RunOutcome(EXIT_DISK_FULL, reason, runs_root, {}, [],
                      f"result: ABORTED (exit {EXIT_DISK_FULL:d})\nended: {reason}\n", kept=False)


def _run(flight: _Flight, options: RunOptions, extra_sinks: list[Sink], progress: Progress | None) -> RunOutcome:
    scenario = flight.scenario
    try:
        run = _Run.prepare(flight, options)
    except OSError as exc:
        if not is_no_space(exc):
            raise
        return _no_room(options.runs_root)
    report, disk = run.report, run.disk
    sinks: list[Sink] = []
    with ExitStack() as stack:
        stack.callback(disk.close)
        tlog = TlogWriter(run.run_dir / "link.tlog")
        stack.callback(lambda: _close(scenario, run, sinks))
        stack.callback(lambda: disk.attempt("link.tlog", tlog.close))
        try:
            context = run.output_context()
            sinks += [sink for open_output in OUTPUTS if (sink := open_output(context)) is not None]
            tlog_writes = FrameSink(disk.guard(lambda _frame: tlog.write_held(), "link.tlog"))  # off the round trip
            run.attach_and_fly([*sinks, *extra_sinks, tlog_writes], progress, stack, disk.guard(tlog, "link.tlog"))
        except OutputError as exc:
            report.reason, report.code = str(exc), EXIT_BAD_INPUT
        except KeyboardInterrupt as exc:
            report.reason, report.code = f"interrupted ({exc.args[0] if exc.args else 'Ctrl-C'})", EXIT_INTERRUPTED
        except Exception as exc:
            if is_no_space(exc):  # a write no watch guards: the end is the same
                filename = getattr(exc, "filename", None)
                disk.failed(Path(filename).name if filename else "the run directory")
                report.reason, report.code = disk.reason(), EXIT_DISK_FULL
            else:
                report.internal_error = traceback.format_exc()
                report.reason, report.code = f"internal error: {type(exc).__name__}: {exc}", EXIT_INTERNAL
    never_connected = report.handle is None and report.code in (EXIT_BOARD, EXIT_BAD_INPUT, EXIT_INTERRUPTED)
    if never_connected and not options.keep_failed:  # nothing flew: no directory to clutter runs/
        shutil.rmtree(run.run_dir, ignore_errors=True)
    return RunOutcome(report.code, report.reason, run.run_dir, report.metrics, report.failures, report.summary,
                      kept=not never_connected or options.keep_failed)


def _relay(handle: BoardHandle, policy: BoardPolicy, endpoints: list[str] | None, pilot: str) -> str:
    """Relay the board's traffic to ground stations (`default_endpoints` when the user names none); with none, a
    board that streams much is asked to stop what nobody reads. Returns the note for the summary's board line."""
    chosen = default_endpoints(policy.default_gcs, pilot == "bench") if endpoints is None else endpoints
    if chosen:
        handle.relay_to(GcsBridge(chosen))
        return f"; ground station relay to {', '.join(chosen)}"
    handle.command_session.stop_unread_streams = policy.stops_unread_streams
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
    if handle.command_session.streams_stopped:
        figures["board_streams_stopped"] = [message_name(i) for i in handle.command_session.streams_stopped]
    return figures


def _close(scenario: Scenario, run: _Run, sinks: list[Sink]) -> None:
    """The summary and metrics say how the run ended; every sink closes with them, in the order they opened."""
    report, run_dir = run.report, run.run_dir
    if report.internal_error is not None:
        run.disk.release()  # the traceback goes in the reserve, whatever the error was
        run.disk.attempt("bench.log", lambda: (run_dir / "bench.log").write_text(report.internal_error or ""))
        report.reason += f" (a bench bug: traceback in {run_dir / 'bench.log'})"
    report.summary = format_summary(scenario, report.board_text, report.autopilot, report.reason, report.code,
                                   report.metrics, report.failures)
    outcome = Outcome(report.final_t_us, {"exit_code": report.code, "reason": report.reason,
                                         "expectations_failed": report.failures, **report.metrics}, report.summary)
    for sink in sinks:
        sink.close(outcome)
