"""`hil run`: its options (the board, links, outputs) checked before any board starts, the run, its report."""

from __future__ import annotations

import argparse
import signal
import sys
from pathlib import Path
from typing import Any

from firmware_interface.emulator.control.registry import CONTROLLERS
from hil.app.arguments import add_zenoh_arguments, load_scenarios, plant_refusal, zenoh_options
from hil.exit_codes import EXIT_BAD_INPUT, EXIT_DISK_FULL, EXIT_INTERRUPTED

MAX_SPEED_FACTOR = 100.0


def _with_run_options(scenario, args: argparse.Namespace):
    """The scenario with --seed, --controller, --plant and --telemetry-rate applied and validated as the file is
    (a seed of -1 or a rate of 0 is bad input), or None after one line per problem."""
    from pydantic import ValidationError

    data = scenario.model_dump()
    if args.seed is not None:
        data["seed"] = args.seed
    if args.controller:
        data["board"]["controller"] = args.controller
    if args.plant:
        data["plant"] = str(Path(args.plant).resolve())  # a path as typed, from the working directory
    for item in args.telemetry_rate or []:
        channel, _, hz = item.partition("=")
        try:
            data["telemetry"]["rates_hz"][channel] = float(hz)
        except ValueError:
            print(f"hil run: --telemetry-rate {item}: expected CHANNEL=HZ, e.g. state=50", file=sys.stderr)
            return None
    try:
        return type(scenario).model_validate(data)
    except ValidationError as exc:
        for error in exc.errors()[:20]:
            print(f"hil run: {'.'.join(str(p) for p in error['loc'])}: {error['msg']}", file=sys.stderr)
        return None


def _cmd_run(args: argparse.Namespace) -> int:
    from hil.app.progress import progress_printer
    from hil.run.runner import run_scenario

    scenarios, bad = load_scenarios([args.scenario])
    if bad:
        return EXIT_BAD_INPUT
    from hil.app.input_checks import run_input_problems

    for problem in (problems := run_input_problems(args)):
        print(f"hil run: {problem}", file=sys.stderr)
    scenario = None if problems else _with_run_options(scenarios[0][1], args)
    options = None if scenario is None else _run_options(args, scenario)
    if scenario is None or options is None:
        return EXIT_BAD_INPUT
    from plant_fmu import PlantError
    from plant_fmu.mapping import MappingError

    try:
        with progress_printer(scenario.name) as progress:
            outcome = run_scenario(scenario, options, progress=progress)
    except (MappingError, PlantError) as exc:  # the plant failed its start-up check: nothing was started
        print("\n".join(plant_refusal(args.scenario, exc)), file=sys.stderr)
        return EXIT_BAD_INPUT
    if outcome.exit_code == EXIT_INTERRUPTED:  # the run is closed: more Ctrl-C only end it as it ends
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
            signal.signal(sig, signal.SIG_IGN)
    print(outcome.summary, end="")
    if not outcome.kept:
        if outcome.exit_code != EXIT_DISK_FULL:  # a full disk says so in its summary
            print(f"run directory removed: the board never connected (--keep-failed keeps {outcome.run_dir})")
        return outcome.exit_code
    print(f"run directory: {outcome.run_dir}")
    if not args.no_report and outcome.exit_code not in (EXIT_INTERRUPTED, EXIT_DISK_FULL):
        report_after_run(outcome.run_dir)
    return outcome.exit_code


def _run_options(args: argparse.Namespace, scenario: Any) -> Any:
    """`hil run`'s options, the board, every link and address checked before any board starts; None after one
    line naming the option that is wrong."""
    from firmware_interface.link import LinkError, parse_connection
    from hil.boards.registry import BoardSpecError
    from hil.run.runner import RunOptions

    for endpoint in args.gcs or []:
        try:
            parse_connection(endpoint)
        except LinkError as exc:
            print(f"hil run: --gcs {endpoint}: {exc}", file=sys.stderr)
            return None
    try:
        board = _board(args)
    except BoardSpecError as exc:
        print(f"hil run: {exc}", file=sys.stderr)
        return None
    if (problem := _speed_problem(args, board, scenario)) is not None:
        print(f"hil run: --speed-factor {args.speed_factor:g}: {problem}", file=sys.stderr)
        return None
    if args.foxglove is not None:
        from hil.outputs.foxglove_live import parse_address

        try:
            parse_address(args.foxglove)
        except ValueError as exc:
            print(f"hil run: --foxglove {exc}", file=sys.stderr)
            return None
    return RunOptions(board=board, foxglove=args.foxglove, realtime=args.realtime, spin_wait=args.spin_wait,
                      gcs=[] if args.no_gcs else args.gcs, runs_root=Path(args.runs), keep_failed=args.keep_failed,
                      telemetry=None if args.no_telemetry else zenoh_options(args),
                      telemetry_rates_hz=scenario.telemetry.rates_hz, speed_factor=args.speed_factor,
                      idle_cpus_poll=not args.power_save)


def _speed_problem(args: argparse.Namespace, board: Any, scenario: Any) -> str | None:
    """Only a lockstep board can be paced faster or slower than the wall clock."""
    if args.speed_factor == 1.0:
        return None
    if not 0 < args.speed_factor <= MAX_SPEED_FACTOR:
        return f"expected a factor above 0 and at most {MAX_SPEED_FACTOR:g}"
    if args.realtime:
        return "--realtime paces at 1; give one of them"
    if scenario.faults.link:
        return "a scenario with link faults runs on the wall clock (its faults are wall-clock effects)"
    if board.policy(scenario).wall_clock:
        return f"{board.label} runs on its own clock; only a lockstep board (the emulator, PX4 SITL) can run faster"
    return None


def _board(args: argparse.Namespace) -> Any:
    """The board the options name: --board SPEC, or its short forms --port, --px4, --px4-hitl (the emulator when
    none is given)."""
    from hil.boards.registry import BoardOptions, BoardSpecError, board_target

    named = [(option, spec) for option, spec in (("--board", args.board), ("--port", args.port and f"port:{args.port}"),
                                                 ("--px4", args.px4 and f"px4:{args.px4}"),
                                                 ("--px4-hitl", args.px4_hitl and f"px4-hitl:{args.px4_hitl}")) if spec]
    option, spec = named[0] if named else ("--board", "emulator")
    if args.mavlink and not spec.startswith("port:"):
        raise BoardSpecError("--mavlink names the command link of a board given with --port (a PX4 SITL started "
                             "by hand)")
    return board_target(spec, BoardOptions(args.mavlink, args.baud, args.connect_timeout, named_by=option))


def report_after_run(run_dir: Path) -> None:
    """report.html at the end of `hil run`; a run without flight data gets a note instead of a page."""
    from hil.reports.html import NoFlightData, write_report
    from hil.reports.rundata import BadRunFile

    try:
        print(f"report: {write_report(run_dir)}")
    except (NoFlightData, BadRunFile) as exc:
        print(f"no report: {exc}")
    except OSError as exc:  # report.html cannot be written (a disk that filled as the run ended)
        print(f"no report: {run_dir / 'report.html'}: {exc.strerror or exc}")


def add_run_command(sub: argparse._SubParsersAction) -> None:
    """`hil run`: every option of a flight."""
    run = sub.add_parser("run", help="fly a scenario through the HIL chain", description=(
        "Fly SCENARIO: the plant FMU and sensor models on this machine, the flight code on a board. Without "
        "--port the built-in emulator runs on a pty in lockstep. --px4 DIR starts PX4 SITL from a build "
        "(PX4-Autopilot/build/px4_sitl_default) for this run, in lockstep; --px4-hitl DIR starts PX4's HITL "
        "code path (a px4_sitl_nolockstep build) on a pty and flies the serial path a Pixhawk gets. With a "
        "Pixhawk (SYS_HITL=1) use --port /dev/ttyACM0 (wall-clock real time). With a PX4 SITL you started "
        "yourself use --port tcpin:127.0.0.1:4560 --mavlink udpout:127.0.0.1:14620 (after mavlink start -u 14620 "
        "-r 4000000 -m onboard -o 14660 in its shell). Exit codes: 0 pass, "
        "1 expectations not met or the flight went wrong, 2 bad input, 3 board/link failure, 4 internal error "
        "(a bench bug; traceback in the run's bench.log), 5 disk full (the flight stopped; hil recover the "
        "recording), 130 interrupted."))
    run.add_argument("scenario", help="scenario YAML file")
    board = run.add_mutually_exclusive_group()
    board.add_argument("--board", metavar="SPEC", help="the board as one name: emulator (the default), px4:DIR, "
                                                       "px4-hitl:DIR, port:CONNECTION")
    board.add_argument("--port", help="board connection: /dev/ttyACM0, serial:PATH:BAUD, tcpin:HOST:PORT, tcp:, "
                                      "udpin:, udpout:")
    board.add_argument("--px4", metavar="DIR", help="start PX4 SITL from this build for the run (lockstep)")
    board.add_argument("--px4-hitl", metavar="DIR", help="start PX4's HITL code path from this px4_sitl_nolockstep "
                                                         "build on a pty (wall-clock, the serial path)")
    run.add_argument("--mavlink", help="separate command link (PX4 SITL: udpout:127.0.0.1:14620, an instance "
                                       "added for the bench)")
    run.add_argument("--baud", type=int, help="serial baud rate where --port names none (default 921600)")
    run.add_argument("--connect-timeout", type=float, metavar="S",
                     help="seconds the board has to send its first heartbeat, and a lockstep board (the emulator, PX4 "
                          "SITL) for each silence until it has booted (default 60 for the emulator and a PX4 SITL you "
                          "started, 30 for --px4 and --px4-hitl, 10 for serial)")
    _add_pacing_arguments(run)
    run.add_argument("--controller", choices=CONTROLLERS,
                     help="override the emulator's controller")
    run.add_argument("--seed", type=int, help="override the scenario's seed")
    run.add_argument("--plant", metavar="MAPPING", help="fly this plant instead of the scenario's: a plant mapping "
                                                        "file (docs/plant.md)")
    run.add_argument("--runs", default="runs", help="where run directories go (default runs/)")
    run.add_argument("--gcs", action="append", metavar="ENDPOINT",
                     help="relay the board's MAVLink to this ground station and back (repeatable; default "
                          "udpout:127.0.0.1:14550 where the bench holds the board's port, and udpout:127.0.0.1:14540 "
                          "too for MAVSDK/MAVROS when the pilot is not the bench; PX4 SITL serves both itself)")
    run.add_argument("--no-gcs", action="store_true", help="no ground-station relay")
    run.add_argument("--no-telemetry", action="store_true", help="do not publish on Zenoh")
    run.add_argument("--keep-failed", action="store_true",
                     help="keep the run directory of an attempt whose board never connected (removed by default)")
    run.add_argument("--no-report", action="store_true", help="do not write report.html at the end of the run")
    run.add_argument("--foxglove", nargs="?", const="127.0.0.1:8765", metavar="HOST:PORT",
                     help="serve the run live to Foxglove over its WebSocket protocol (default 127.0.0.1:8765)")
    run.add_argument("--telemetry-rate", action="append", metavar="CHANNEL=HZ", help="e.g. state=100 (repeatable)")
    add_zenoh_arguments(run)
    run.set_defaults(func=_cmd_run)


def _add_pacing_arguments(run: argparse.ArgumentParser) -> None:
    """How fast the run goes, and what of the machine it may take for it."""
    run.add_argument("--realtime", action="store_true", help="pace the emulator in wall-clock real time")
    run.add_argument("--speed-factor", type=float, default=1.0, metavar="N",
                     help="pace a lockstep board at N times the wall clock (as PX4_SIM_SPEED_FACTOR; PX4 SITL is told "
                          "it). An outside pilot's run is paced at 1 by default; a faster one lets a script fly N "
                          "times faster than it would take a person")
    run.add_argument("--spin-wait", action="store_true",
                     help="wait for the board's lockstep replies by polling a while before sleeping, and the "
                          "emulator the bench starts for its frames: faster with a core free for each and idle CPUs "
                          "sleeping (--power-save), slower otherwise (docs/performance.md)")
    run.add_argument("--power-save", action="store_true",
                     help="let idle CPUs sleep while a lockstep run flies; by default the bench asks the kernel to "
                          "keep them polling (/dev/cpu_dma_latency, as cyclictest does), which saves each wake-up of a "
                          "step the CPU's exit from idle. A paced run always leaves them (docs/architecture.md)")
