"""`hil`: the bench's command line."""

from __future__ import annotations

import argparse
import errno
import signal
import sys
from pathlib import Path
from typing import Any

from firmware_interface.emulator.control.registry import CONTROLLERS
from hil.exit_codes import EXIT_BAD_INPUT, EXIT_BOARD, EXIT_DISK_FULL, EXIT_INTERRUPTED, EXIT_OK


def _cmd_fmu_build(args: argparse.Namespace) -> int:
    from plant_fmu.build import build_fmu, default_fmu_path

    out = Path(args.out) if args.out else default_fmu_path()
    path, rebuilt = build_fmu(out, force=args.force)
    print(f"{'built' if rebuilt else 'up to date'}: {path}")
    return EXIT_OK


def _cmd_fmu_check(args: argparse.Namespace) -> int:
    from fmpy import simulate_fmu
    from fmpy.validation import validate_fmu

    from plant_fmu.build import ensure_fmu

    path = ensure_fmu(Path(args.fmu) if args.fmu else None)
    problems = validate_fmu(str(path))
    for problem in problems:
        print(f"{path}: {problem}")
    if problems:
        return EXIT_BAD_INPUT
    result = simulate_fmu(str(path), stop_time=1.0, output_interval=0.004, output=["pos_d", "specific_force_z"])
    print(f"{path}: valid FMI 2.0 co-simulation FMU; fmpy.simulate_fmu ran {len(result)} steps, "
          f"at rest pos_d = {result['pos_d'][-1]:.3f} m, accel z = {result['specific_force_z'][-1]:.3f} m/s^2")
    return EXIT_OK


def _cmd_fmu_hover(args: argparse.Namespace) -> int:
    from plant_fmu.demo import fly_hover

    print(f"{'t [s]':>6} {'alt [m]':>8} {'climb [m/s]':>12}")
    for t, alt, climb in fly_hover(args.seconds, args.altitude):
        print(f"{t:6.1f} {alt:8.3f} {climb:12.3f}")
    return EXIT_OK


def _load(paths: list[str]) -> tuple[list[tuple[str, Any]], int]:
    """The scenarios that load, each as (path, scenario), and how many did not (their problems printed)."""
    from hil.scenario.loader import ScenarioError, load_scenario

    scenarios, bad = [], 0
    for path in paths:
        try:
            scenarios.append((path, load_scenario(Path(path))))
        except ScenarioError as exc:
            for problem in exc.problems:
                print(problem, file=sys.stderr)
            bad += 1
    return scenarios, bad


def _cmd_check(args: argparse.Namespace) -> int:
    scenarios, bad = _load(args.files)
    for path, scenario in scenarios:
        print(f"{path}: ok ({scenario.name}: {scenario.reference.type}, {scenario.duration_s:g} s)")
    return EXIT_BAD_INPUT if bad else EXIT_OK


def _with_run_options(scenario, args: argparse.Namespace):
    """The scenario with --seed, --controller and --telemetry-rate applied and validated as the file is
    (a seed of -1 or a rate of 0 is bad input), or None after one line per problem."""
    from pydantic import ValidationError

    data = scenario.model_dump()
    if args.seed is not None:
        data["seed"] = args.seed
    if args.controller:
        data["board"]["controller"] = args.controller
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

    scenarios, bad = _load([args.scenario])
    if bad:
        return EXIT_BAD_INPUT
    from hil.app.input_checks import run_input_problems

    for problem in (problems := run_input_problems(args)):
        print(f"hil run: {problem}", file=sys.stderr)
    scenario = None if problems else _with_run_options(scenarios[0][1], args)
    options = None if scenario is None else _run_options(args, scenario)
    if scenario is None or options is None:
        return EXIT_BAD_INPUT
    with progress_printer(scenario.name) as progress:
        outcome = run_scenario(scenario, options, progress=progress)
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
        _report_after_run(outcome.run_dir)
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
    if args.foxglove is not None:
        from hil.outputs.foxglove_live import parse_address

        try:
            parse_address(args.foxglove)
        except ValueError as exc:
            print(f"hil run: --foxglove {exc}", file=sys.stderr)
            return None
    return RunOptions(board=board, foxglove=args.foxglove, realtime=args.realtime,
                      gcs=[] if args.no_gcs else args.gcs, runs_root=Path(args.runs), keep_failed=args.keep_failed,
                      telemetry=None if args.no_telemetry else _zenoh_options(args),
                      telemetry_rates_hz=scenario.telemetry.rates_hz)


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


def _zenoh_options(args: argparse.Namespace):
    from hil.outputs.zenoh_session import ZenohOptions

    endpoints = bool(args.zenoh_connect or args.zenoh_listen)
    return ZenohOptions(connect=args.zenoh_connect or [], listen=args.zenoh_listen or [],
                        config_file=Path(args.zenoh_config) if args.zenoh_config else None,
                        multicast_scouting=not endpoints)


def _add_zenoh_arguments(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("Zenoh", "default: a peer that finds others on this machine by multicast "
                                               "scouting; with endpoints, scouting is off")
    group.add_argument("--zenoh-connect", action="append", metavar="ENDPOINT", help="e.g. tcp/192.0.2.10:7447")
    group.add_argument("--zenoh-listen", action="append", metavar="ENDPOINT", help="e.g. tcp/0.0.0.0:7447")
    group.add_argument("--zenoh-config", metavar="FILE", help="a Zenoh JSON5 configuration file")


def _cmd_watch(args: argparse.Namespace) -> int:
    from hil.app.input_checks import zenoh_problem
    from hil.app.watch import watch

    if problem := zenoh_problem(args.zenoh_config, _zenoh_options(args)):
        print(f"hil watch: {problem}", file=sys.stderr)
        return EXIT_BAD_INPUT
    return watch(None if args.latest else args.run_id, _zenoh_options(args), args.wait)


def _cmd_echo(args: argparse.Namespace) -> int:
    from hil.app.input_checks import zenoh_problem
    from hil.app.watch import echo, key_expr_problem

    problem = key_expr_problem(args.key_expr)
    if problem:
        print(f"hil echo: key expression {args.key_expr!r}: {problem}; e.g. 'hil/**/state'", file=sys.stderr)
        return EXIT_BAD_INPUT
    if problem := zenoh_problem(args.zenoh_config, _zenoh_options(args)):
        print(f"hil echo: {problem}", file=sys.stderr)
        return EXIT_BAD_INPUT
    return echo(args.key_expr, _zenoh_options(args))


def _cmd_report(args: argparse.Namespace) -> int:
    from hil.reports.html import NoFlightData, write_report
    from hil.reports.png import report
    from hil.reports.rundata import BadRunFile

    run_dir = Path(args.run_dir)
    if not (run_dir / "recording.mcap").is_file():
        print(f"hil report: {run_dir}: not a run directory (no recording.mcap)", file=sys.stderr)
        return EXIT_BAD_INPUT
    try:
        print(write_report(run_dir))
        for figure in report(run_dir, paper_frame=args.paper_frame):
            print(figure)
    except (NoFlightData, BadRunFile) as exc:
        print(f"hil report: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except OSError as exc:  # the report's files cannot be written
        print(f"hil report: {exc.filename or run_dir}: {exc.strerror or exc}", file=sys.stderr)
        return EXIT_DISK_FULL if exc.errno in (errno.ENOSPC, errno.EDQUOT) else EXIT_BAD_INPUT
    return EXIT_OK


def _report_after_run(run_dir: Path) -> None:
    """report.html at the end of `hil run`; a run without flight data gets a note instead of a page."""
    from hil.reports.html import NoFlightData, write_report
    from hil.reports.rundata import BadRunFile

    try:
        print(f"report: {write_report(run_dir)}")
    except (NoFlightData, BadRunFile) as exc:
        print(f"no report: {exc}")
    except OSError as exc:  # report.html cannot be written (a disk that filled as the run ended)
        print(f"no report: {run_dir / 'report.html'}: {exc.strerror or exc}")


def _cmd_recover(args: argparse.Namespace) -> int:
    from hil.outputs.recover import RecoverError, recover

    run_dir = Path(args.run_dir)
    try:
        result = recover(run_dir)
    except RecoverError as exc:
        print(f"hil recover: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    if result.already_complete:
        print(f"{run_dir / 'recording.mcap'}: complete already (indexed), nothing to do")
    else:
        print(f"{run_dir / 'recording.mcap'}: recovered {result.messages} messages; the cut file is kept as "
              "recording.mcap.cut; summary.txt marked as recovered")
    return EXIT_OK


def _cmd_foxglove(args: argparse.Namespace) -> int:
    import threading

    from hil.app.foxglove_bridge import bridge_zenoh
    from hil.app.input_checks import zenoh_problem
    from hil.outputs.foxglove_live import parse_address
    from hil.outputs.zenoh_session import open_session

    try:
        parse_address(args.listen)
    except ValueError as exc:
        print(f"hil foxglove: --listen {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    if problem := zenoh_problem(args.zenoh_config, _zenoh_options(args)):
        print(f"hil foxglove: {problem}", file=sys.stderr)
        return EXIT_BAD_INPUT
    session = open_session(_zenoh_options(args))
    stop = threading.Event()
    try:
        reason = bridge_zenoh(session, args.run_id, args.listen, args.wait, stop)
    except KeyboardInterrupt:
        return EXIT_INTERRUPTED
    except RuntimeError as exc:  # foxglove-sdk: the address is taken
        print(f"hil foxglove: --listen {args.listen}: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    finally:
        session.close()
    print(f"hil foxglove: {reason}")
    return EXIT_OK if reason.endswith("ended") else EXIT_BOARD


def _cmd_sweep(args: argparse.Namespace) -> int:
    from hil.app.progress import sample_progress
    from hil.scenario.loader import ScenarioError
    from hil.sweep import ClusterUnreachable, SweepError, load_sweep, run_spec

    try:
        spec = load_sweep(Path(args.sweep))
        out = Path(args.out) if args.out else Path("runs") / f"sweep-{spec.name}"
        with sample_progress(spec.name) as progress:
            outcome = run_spec(spec, out, jobs=args.jobs, cluster=args.cluster, limit=args.limit, resume=args.resume,
                               on_progress=progress)
    except (SweepError, ScenarioError, ClusterUnreachable) as exc:
        for line in str(exc).splitlines():
            print(f"hil sweep: {line}" if line.startswith("--") else line, file=sys.stderr)  # an option, or a file
        return EXIT_BOARD if isinstance(exc, ClusterUnreachable) else EXIT_BAD_INPUT
    failed = sum(r["exit_code"] not in (0, 1) for r in outcome.rows)
    print(f"{len(outcome.rows)} of {outcome.total} samples finished ({failed} failed to fly)"
          f"{'; interrupted: hil sweep --resume continues' if outcome.interrupted else ''}")
    print(f"written: {outcome.out / 'sweep.parquet'}, {outcome.out / 'sweep.md'}")
    return EXIT_INTERRUPTED if outcome.interrupted else EXIT_OK


def _cmd_compare(args: argparse.Namespace) -> int:
    from hil.app.compare import compare
    from hil.app.input_checks import compare_problems

    scenarios, bad = _load([args.scenario])
    if bad:
        return EXIT_BAD_INPUT
    scenario = scenarios[0][1]
    controllers = [c.strip() for c in args.controllers.split(",") if c.strip()]
    out = Path(args.out) if args.out else Path("runs") / f"compare-{scenario.name}"
    problems = compare_problems(args, controllers, out)
    for problem in problems:
        print(f"hil compare: {problem}", file=sys.stderr)
    if problems:
        return EXIT_BAD_INPUT
    seeds = [scenario.seed + i for i in range(args.seeds)]
    result, markdown = compare(Path(args.scenario), scenario, controllers, seeds, args.jobs, out)
    print(markdown, end="")
    print(f"written: {out / 'comparison.md'}, {out / 'comparison.json'}, plots under {out}")
    return EXIT_OK if all(r["exit_code"] in (0, 1) for r in result["runs"]) else EXIT_BOARD


def _cmd_ports(args: argparse.Namespace) -> int:
    from serial.tools import list_ports

    from firmware_interface.link.ports import pixhawk_maker

    ports = sorted(list_ports.comports(), key=lambda p: p.device)
    if not ports:
        print("no serial ports found (a Pixhawk on USB appears as /dev/ttyACM*)")
    found = 0
    for port in ports:
        maker = pixhawk_maker(port.vid, port.description)
        found += maker is not None
        note = f"\tlooks like a Pixhawk ({maker}): hil run SCENARIO --port {port.device}" if maker else ""
        print(f"{port.device}\t{port.description}\t{port.hwid}{note}")
    if not found:
        print("no Pixhawk found (PX4 boards enumerate on USB with the vendor ids of PX4, CubePilot or Holybro)")
    return EXIT_OK


def _emulate(argv: list[str]) -> int:
    """`hil emulate ...` is the emulator's own command line (its options and --help), passed through whole."""
    from firmware_interface.emulator.__main__ import main as emulate

    return emulate(argv)


def _add_fmu_commands(sub: argparse._SubParsersAction) -> None:
    """`hil fmu build | check | hover`."""
    fmu = sub.add_parser("fmu", help="build and check the plant FMU").add_subparsers(dest="fmu_command", required=True)
    build = fmu.add_parser("build", help="build Quadrotor.fmu from source (only if sources changed)")
    build.add_argument("--out", help="output path (default build/Quadrotor.fmu)")
    build.add_argument("--force", action="store_true", help="rebuild even if up to date")
    build.set_defaults(func=_cmd_fmu_build)
    check = fmu.add_parser("check", help="validate the FMU with fmpy and simulate one second")
    check.add_argument("--fmu", help="FMU to check (default: the built one)")
    check.set_defaults(func=_cmd_fmu_check)
    hover = fmu.add_parser("hover", help="fly a short hover of the plant alone in a plain fmpy loop")
    hover.add_argument("--seconds", type=float, default=5.0)
    hover.add_argument("--altitude", type=float, default=2.0, help="hover altitude in m")
    hover.set_defaults(func=_cmd_fmu_hover)


def _add_run_command(sub: argparse._SubParsersAction) -> None:
    """`hil run`: every option of a flight."""
    run = sub.add_parser("run", help="fly a scenario through the HIL chain", description=(
        "Fly SCENARIO: the plant FMU and sensor models on this machine, the flight code on a board. Without "
        "--port the built-in emulator runs on a pty in lockstep. --px4 DIR starts PX4 SITL from a build "
        "(PX4-Autopilot/build/px4_sitl_default) for this run, in lockstep; --px4-hitl DIR starts PX4's HITL "
        "code path (a px4_sitl_nolockstep build) on a pty and flies the serial path a Pixhawk gets. With a "
        "Pixhawk (SYS_HITL=1) use --port /dev/ttyACM0 (wall-clock real time). With a PX4 SITL you started "
        "yourself use --port tcpin:127.0.0.1:4560 --mavlink udpout:127.0.0.1:14580. Exit codes: 0 pass, "
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
    run.add_argument("--mavlink", help="separate command link (PX4 SITL: udpout:127.0.0.1:14580)")
    run.add_argument("--baud", type=int, help="serial baud rate where --port names none (default 921600)")
    run.add_argument("--connect-timeout", type=float, metavar="S",
                     help="seconds to wait for a board you attached (default 60 for PX4 SITL, 10 for serial)")
    run.add_argument("--realtime", action="store_true", help="pace the emulator in wall-clock real time")
    run.add_argument("--controller", choices=CONTROLLERS,
                     help="override the emulator's controller")
    run.add_argument("--seed", type=int, help="override the scenario's seed")
    run.add_argument("--runs", default="runs", help="where run directories go (default runs/)")
    run.add_argument("--gcs", action="append", metavar="ENDPOINT",
                     help="relay the board's MAVLink to this ground station and back (repeatable; default "
                          "udpout:127.0.0.1:14550 where the bench holds the board's port; PX4 SITL has its own)")
    run.add_argument("--no-gcs", action="store_true", help="no ground-station relay")
    run.add_argument("--no-telemetry", action="store_true", help="do not publish on Zenoh")
    run.add_argument("--keep-failed", action="store_true",
                     help="keep the run directory of an attempt whose board never connected (removed by default)")
    run.add_argument("--no-report", action="store_true", help="do not write report.html at the end of the run")
    run.add_argument("--foxglove", nargs="?", const="127.0.0.1:8765", metavar="HOST:PORT",
                     help="serve the run live to Foxglove over its WebSocket protocol (default 127.0.0.1:8765)")
    run.add_argument("--telemetry-rate", action="append", metavar="CHANNEL=HZ", help="e.g. state=100 (repeatable)")
    _add_zenoh_arguments(run)
    run.set_defaults(func=_cmd_run)


def _add_live_commands(sub: argparse._SubParsersAction) -> None:
    """`hil watch`, `hil echo`, `hil foxglove`: views of a run on Zenoh."""
    watch = sub.add_parser("watch", help="live view of a running bench (Zenoh)")
    target = watch.add_mutually_exclusive_group(required=True)
    target.add_argument("run_id", nargs="?", help="a run id (its run directory's name)")
    target.add_argument("--latest", action="store_true", help="the newest running bench, or the next to start")
    watch.add_argument("--wait", type=float, default=60.0, help="seconds to wait for a run to appear")
    _add_zenoh_arguments(watch)
    watch.set_defaults(func=_cmd_watch)
    echo = sub.add_parser("echo", help="print telemetry samples as JSON lines, e.g. hil echo 'hil/**/state'")
    echo.add_argument("key_expr")
    _add_zenoh_arguments(echo)
    echo.set_defaults(func=_cmd_echo)
    foxglove = sub.add_parser("foxglove", help="serve a run seen on Zenoh (any machine's bench) to Foxglove")
    foxglove.add_argument("run_id", nargs="?", help="a run id (default: the newest running bench)")
    foxglove.add_argument("--listen", default="127.0.0.1:8765", metavar="HOST:PORT",
                          help="Foxglove WebSocket address (default 127.0.0.1:8765)")
    foxglove.add_argument("--wait", type=float, default=60.0, help="seconds to wait for a run to appear")
    _add_zenoh_arguments(foxglove)
    foxglove.set_defaults(func=_cmd_foxglove)


def _add_file_commands(sub: argparse._SubParsersAction) -> None:
    """`hil check`, `hil report`, `hil recover`: work on files."""
    check = sub.add_parser("check", help="validate scenario files without running them")
    check.add_argument("files", nargs="+")
    check.set_defaults(func=_cmd_check)
    report = sub.add_parser("report", help="report.html of a run, and PNG figures (cf. the paper's Figures 5-18)")
    report.add_argument("run_dir")
    report.add_argument("--paper-frame", action="store_true",
                        help="draw the figures as the paper does (z up, angles γ = -roll, θ = -pitch, ψ, the paper's "
                             "figure numbers) in report/paper_frame/; default: NED")
    report.set_defaults(func=_cmd_report)
    recover = sub.add_parser("recover", help="rebuild a recording cut short (kill -9, power loss) into an "
                                             "indexed MCAP")
    recover.add_argument("run_dir")
    recover.set_defaults(func=_cmd_recover)


def _add_study_commands(sub: argparse._SubParsersAction) -> None:
    """`hil sweep`, `hil compare`: many flights."""
    sweep = sub.add_parser("sweep", help="Monte Carlo / parameter sweep of a scenario, on Dask (hil sweep SWEEP.yaml)")
    sweep.add_argument("sweep", help="sweep YAML file (see sweeps/)")
    sweep.add_argument("--jobs", type=int, default=2, help="LocalCluster worker processes (one run each at a time)")
    sweep.add_argument("--cluster", metavar="ADDRESS", help="an existing Dask scheduler, e.g. tcp://10.0.0.5:8786")
    sweep.add_argument("--limit", type=int, help="fly only the first N samples")
    sweep.add_argument("--resume", action="store_true", help="continue a stopped sweep in --out")
    sweep.add_argument("--out", help="results directory (default runs/sweep-<name>)")
    sweep.set_defaults(func=_cmd_sweep)
    compare = sub.add_parser("compare", help="fly a scenario with several controllers and compare (Tables 1-2)")
    compare.add_argument("scenario")
    compare.add_argument("--controllers", default="smarc,smpid,backstepping")
    compare.add_argument("--seeds", type=int, default=1, help="seeds per controller, from the scenario's seed up")
    compare.add_argument("--jobs", type=int, default=2, help="flights in parallel (each is two processes)")
    compare.add_argument("--out", help="output directory (default runs/compare-<scenario>)")
    compare.set_defaults(func=_cmd_compare)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="hil", description="Hardware-in-the-loop bench for PX4 quadrotors")
    sub = parser.add_subparsers(dest="command", required=True)

    for add in (_add_fmu_commands, _add_run_command, _add_live_commands, _add_file_commands, _add_study_commands):
        add(sub)
    ports = sub.add_parser("ports", help="list serial ports (where a Pixhawk shows up)")
    ports.set_defaults(func=_cmd_ports)
    sub.add_parser("emulate", add_help=False, help="run the software flight controller on a port "
                                                   "(hil emulate --help)")
    return parser


def main(argv: list[str] | None = None) -> int:
    from plant_fmu.build import FmuBuildError

    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["emulate"]:
        return _emulate(argv[1:])
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args))
    except FmuBuildError as exc:
        print(f"hil: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        return EXIT_INTERRUPTED


if __name__ == "__main__":
    sys.exit(main())
