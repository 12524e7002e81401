"""`hil watch`, `hil echo`, `hil foxglove`: views of a running bench on Zenoh."""

from __future__ import annotations

import argparse
import sys

from hil.app.arguments import add_zenoh_arguments, zenoh_options
from hil.exit_codes import EXIT_BAD_INPUT, EXIT_BOARD, EXIT_INTERRUPTED, EXIT_OK


def _cmd_watch(args: argparse.Namespace) -> int:
    from hil.app.input_checks import zenoh_problem
    from hil.app.watch import watch

    if problem := zenoh_problem(args.zenoh_config, zenoh_options(args)):
        print(f"hil watch: {problem}", file=sys.stderr)
        return EXIT_BAD_INPUT
    return watch(None if args.latest else args.run_id, zenoh_options(args), args.wait)


def _cmd_echo(args: argparse.Namespace) -> int:
    from hil.app.input_checks import zenoh_problem
    from hil.app.watch import echo, key_expr_problem

    problem = key_expr_problem(args.key_expr)
    if problem:
        print(f"hil echo: key expression {args.key_expr!r}: {problem}; e.g. 'hil/**/state'", file=sys.stderr)
        return EXIT_BAD_INPUT
    if problem := zenoh_problem(args.zenoh_config, zenoh_options(args)):
        print(f"hil echo: {problem}", file=sys.stderr)
        return EXIT_BAD_INPUT
    return echo(args.key_expr, zenoh_options(args))


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
    if problem := zenoh_problem(args.zenoh_config, zenoh_options(args)):
        print(f"hil foxglove: {problem}", file=sys.stderr)
        return EXIT_BAD_INPUT
    session = open_session(zenoh_options(args))
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


def add_live_commands(sub: argparse._SubParsersAction) -> None:
    """`hil watch`, `hil echo`, `hil foxglove`: views of a run on Zenoh."""
    watch = sub.add_parser("watch", help="live view of a running bench (Zenoh)")
    target = watch.add_mutually_exclusive_group(required=True)
    target.add_argument("run_id", nargs="?", help="a run id (its run directory's name)")
    target.add_argument("--latest", action="store_true", help="the newest running bench, or the next to start")
    watch.add_argument("--wait", type=float, default=60.0, help="seconds to wait for a run to appear")
    add_zenoh_arguments(watch)
    watch.set_defaults(func=_cmd_watch)
    echo = sub.add_parser("echo", help="print telemetry samples as JSON lines, e.g. hil echo 'hil/**/state'")
    echo.add_argument("key_expr")
    add_zenoh_arguments(echo)
    echo.set_defaults(func=_cmd_echo)
    foxglove = sub.add_parser("foxglove", help="serve a run seen on Zenoh (any machine's bench) to Foxglove")
    foxglove.add_argument("run_id", nargs="?", help="a run id (default: the newest running bench)")
    foxglove.add_argument("--listen", default="127.0.0.1:8765", metavar="HOST:PORT",
                          help="Foxglove WebSocket address (default 127.0.0.1:8765)")
    foxglove.add_argument("--wait", type=float, default=60.0, help="seconds to wait for a run to appear")
    add_zenoh_arguments(foxglove)
    foxglove.set_defaults(func=_cmd_foxglove)
