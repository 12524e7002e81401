"""Options of `hil run`, `hil compare` and the Zenoh commands checked before anything starts, each problem one
line naming the option (the board choice of `hil run` is checked where it is made, in the CLI)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from firmware_interface.emulator.control.registry import CONTROLLERS
from firmware_interface.link import LinkError, parse_connection
from hil.host.addresses import unresolved
from hil.host.paths import unwritable

if TYPE_CHECKING:
    from hil.outputs.telemetry import ZenohOptions

MAX_COMPARE_SEEDS = 1000  # flights per controller: a comparison past this is a sweep


def run_input_problems(args: argparse.Namespace) -> list[str]:
    """`hil run`'s options outside the board choice that cannot be used, one line each, before anything starts."""
    return [p for p in (_runs_problem(args), _baud_problem(args), _connect_timeout_problem(args),
                        *_endpoint_problems(args)) if p]


def _runs_problem(args: argparse.Namespace) -> str | None:
    reason = unwritable(Path(args.runs))
    return f"--runs {args.runs}: {reason}" if reason else None


def _baud_problem(args: argparse.Namespace) -> str | None:
    from serial import SerialBase

    if args.baud is None or args.baud in SerialBase.BAUDRATES:
        return None
    return (f"--baud {args.baud}: not a serial baud rate; expected one of {', '.join(map(str, SerialBase.BAUDRATES))}"
            " (PX4's USB and TELEM ports: 57600, 115200, 921600)")


def _connect_timeout_problem(args: argparse.Namespace) -> str | None:
    """A board needs some time to speak: 0 or less (or NaN) is not a timeout, and would have fallen back to the
    default unsaid."""
    timeout = args.connect_timeout
    if timeout is None or timeout > 0:
        return None
    return f"--connect-timeout {timeout:g}: expected seconds above 0"


def _endpoint_problems(args: argparse.Namespace) -> list[str]:
    """Every --gcs and --mavlink endpoint parsed, and its host resolved: a name that does not resolve is bad
    input before any board starts, not a relay that fails in flight."""
    problems = []
    for option, endpoint in [*(("--gcs", e) for e in args.gcs or []), *([("--mavlink", args.mavlink)]
                                                                       if args.mavlink else [])]:
        try:
            connection = parse_connection(endpoint)
        except LinkError as exc:
            problems.append(f"{option} {endpoint}: {exc}")
            continue
        if connection.kind != "serial" and (reason := unresolved(connection.address)):
            problems.append(f"{option} {endpoint}: {reason}")
    return problems


def compare_problems(args: argparse.Namespace, controllers: list[str], out: Path) -> list[str]:
    """`hil compare`'s options that cannot be used, one line each."""
    from hil.sweep.options import option_problems

    problems = option_problems(args.jobs, None, None, out, resume=False)
    unknown = sorted(set(controllers) - set(CONTROLLERS))
    if unknown or not controllers:
        problems.append(f"--controllers {args.controllers}: {'unknown ' + ', '.join(unknown) if unknown else 'none'}"
                        f"; expected a comma-separated list of {', '.join(CONTROLLERS)}")
    if not 1 <= args.seeds <= MAX_COMPARE_SEEDS:
        problems.append(f"--seeds {args.seeds}: expected 1 to {MAX_COMPARE_SEEDS} seeds per controller")
    return problems


def zenoh_problem(config_file: str | None, options: ZenohOptions) -> str | None:
    """Why the Zenoh options make no configuration (a file missing or malformed, an endpoint Zenoh refuses)."""
    import zenoh

    from hil.outputs.zenoh_session import zenoh_config

    if config_file and not Path(config_file).is_file():
        return f"--zenoh-config {config_file}: no such file"
    try:
        zenoh_config(options)
    except zenoh.ZError as exc:
        return f"Zenoh: {' '.join(str(exc).split(' at /')[0].split())}"
    return None
