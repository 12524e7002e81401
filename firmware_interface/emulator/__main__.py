"""Run the emulated board on a port: `python -m firmware_interface.emulator --port /dev/pts/5`."""

from __future__ import annotations

import argparse
import gc
import signal
import sys
from pathlib import Path

from firmware_interface.airframes import AIRFRAME_NAMES
from firmware_interface.emulator.config import load_config
from firmware_interface.emulator.control.registry import CONTROLLERS
from firmware_interface.emulator.firmware import EmulatedBoard
from firmware_interface.emulator.warm_up import compile_flight_code
from firmware_interface.link import LinkError, open_link


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="hil emulate", description=(
        "A software flight controller that speaks PX4's HIL protocol (HEARTBEAT, HIL_SENSOR/HIL_GPS in, "
        "HIL_ACTUATOR_CONTROLS out, COMMAND_LONG arm/offboard, SET_POSITION_TARGET_LOCAL_NED) and flies "
        "the paper's controllers."))
    parser.add_argument("--port", required=True, help="serial device or pty path, or tcp:/udp: connection string")
    parser.add_argument("--controller", choices=CONTROLLERS, help="overrides the config file")
    parser.add_argument("--airframe", choices=AIRFRAME_NAMES, help="nominal vehicle preset")
    parser.add_argument("--state-source", choices=("estimator", "truth"), help="truth = fly on HIL_STATE_QUATERNION")
    parser.add_argument("--config", type=Path, help="YAML file with EmulatorConfig fields")
    parser.add_argument("--one-boot-heartbeat", action="store_true",
                        help="before the first HIL_SENSOR send one HEARTBEAT, not one each wall-clock second: for a "
                             "peer that holds the port before the emulator starts and waits for it (the bench's pty), "
                             "so that nothing the emulator sends depends on the wall clock")
    parser.add_argument("--spin-wait", action="store_true",
                        help="wait for the next frame by polling a while before sleeping, as `hil run --spin-wait` "
                             "does for the replies: faster in lockstep with a core to spare for each side")
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    overrides = {k: v for k, v in (("controller", args.controller), ("airframe", args.airframe),
                                   ("state_source", args.state_source)) if v is not None}
    try:
        config = load_config(args.config, overrides)
        link = open_link(args.port)
    except (LinkError, ValueError, OSError) as exc:
        print(f"hil emulate: {exc}", file=sys.stderr)
        return 2
    stopping = False

    def stop(*_: object) -> None:
        nonlocal stopping
        stopping = True

    signal.signal(signal.SIGTERM, stop)
    signal.signal(signal.SIGINT, stop)
    compile_flight_code(config)  # before the first heartbeat, so the bench's start-up wait covers it
    if args.spin_wait:
        link.spin_wait()
    board = EmulatedBoard(link, config, repeat_boot_heartbeat=not args.one_boot_heartbeat)
    gc.freeze()  # start-up objects live to the end: a full collection over them stalls the loop ~10s of ms
    reason = board.run(lambda: stopping)
    link.close()
    print(f"hil emulate: {reason}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
