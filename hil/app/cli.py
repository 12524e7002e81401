"""`hil`: the bench's command line."""

from __future__ import annotations

import argparse
import errno
import gc
import sys
from pathlib import Path
from typing import Any

from hil.app.arguments import load_scenarios, plant_at_rest_problems
from hil.app.live_commands import add_live_commands
from hil.app.run_command import add_run_command
from hil.app.study_commands import add_study_commands
from hil.exit_codes import EXIT_BAD_INPUT, EXIT_DISK_FULL, EXIT_INTERRUPTED, EXIT_OK


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


def _flown(scenario: Any) -> str:
    """What a scenario flies, in a few words: the bench's reference, or who else flies (and what mission)."""
    pilot = scenario.pilot
    if pilot.type == "bench":
        return str(scenario.reference.type)
    mission = f" of {len(pilot.items)} mission items" if pilot.items else ""
    return f"{pilot.type} pilot{mission}, end {scenario.end}"


def _cmd_check(args: argparse.Namespace) -> int:
    """Each file against the schema and its plant's files, then its plant opened and checked at rest."""
    scenarios, bad = load_scenarios(args.files)
    for path, scenario in scenarios:
        if problems := plant_at_rest_problems(path, scenario):
            print("\n".join(problems), file=sys.stderr)
            bad += 1
        else:
            print(f"{path}: ok ({scenario.name}: {_flown(scenario)}, {scenario.duration_s:g} s)")
    return EXIT_BAD_INPUT if bad else EXIT_OK


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


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="hil", description="Hardware-in-the-loop bench for PX4 quadrotors")
    sub = parser.add_subparsers(dest="command", required=True)

    for add in (_add_fmu_commands, add_run_command, add_live_commands, _add_file_commands, add_study_commands):
        add(sub)
    ports = sub.add_parser("ports", help="list serial ports (where a Pixhawk shows up)")
    ports.set_defaults(func=_cmd_ports)
    sub.add_parser("emulate", add_help=False, help="run the software flight controller on a port "
                                                   "(hil emulate --help)")
    return parser


def main(argv: list[str] | None = None) -> int:
    if argv is None:  # the command line: the process ends with the command
        try:
            return _command(sys.argv[1:])
        finally:
            # the interpreter's shutdown collects garbage as it clears each module: over the ~60k objects the
            # imports built that took 0.15-0.3 s of every command. Frozen, they are freed all the same, untraversed.
            gc.freeze()
    return _command(argv)


def _command(argv: list[str]) -> int:
    from plant_fmu.build import FmuBuildError

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
