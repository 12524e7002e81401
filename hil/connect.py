"""Attach the bench to a board: the built-in emulator on a fresh pty, or a real port."""

from __future__ import annotations

import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import yaml

from firmware_interface.board import BoardKind, BoardSession
from firmware_interface.link import Link, open_link, open_pty_pair, parse_connection
from hil.scenario.schema import Scenario
from hil.sensors.config import GPS_PROFILES, resolve


@dataclass
class BoardHandle:
    session: BoardSession  # the HIL link (sensors out, actuators in)
    commands: BoardSession  # heartbeat, arming, offboard, setpoints: the same session unless --mavlink
    kind: BoardKind
    description: str
    process: subprocess.Popen[bytes] | None = None

    def close(self) -> None:
        if self.process is not None and self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(2.0)
            except subprocess.TimeoutExpired:
                self.process.kill()
        self.session.link.close()
        if self.commands is not self.session:
            self.commands.link.close()


def emulator_config(scenario: Scenario) -> dict:
    """What the emulator is told: the scenario's board settings, and EKF2_GPS_DELAY set to the receiver's
    delay, as a user would set the parameter for the GPS on the vehicle."""
    board = scenario.board
    gps = resolve(GPS_PROFILES, scenario.sensors.gps.profile, scenario.sensors.gps.overrides)
    config = {"airframe": board.airframe or scenario.vehicle.preset, "controller": board.controller,
              "state_source": board.state_source, **board.config}
    estimator = dict(config.get("estimator", {}))
    estimator.setdefault("gps_delay_s", gps.delay_s)
    config["estimator"] = estimator
    return config


def start_emulator(scenario: Scenario, run_dir: Path, watchdog_s: float) -> BoardHandle:
    config_path = run_dir / "emulator.yaml"
    config_path.write_text(yaml.safe_dump(emulator_config(scenario), sort_keys=False))
    pair = open_pty_pair()
    log = open(run_dir / "emulator.log", "wb")  # noqa: SIM115 - owned by the child process
    process = subprocess.Popen([sys.executable, "-m", "firmware_interface.emulator", "--port", pair.slave_path,
                                "--config", str(config_path)], stdout=log, stderr=log,
                               start_new_session=True)  # a terminal Ctrl-C stops the bench, which stops it
    session = BoardSession(Link(pair.master), BoardKind.EMULATOR, watchdog_s=watchdog_s)
    handle = BoardHandle(session, session, BoardKind.EMULATOR, f"emulator on {pair.slave_path}", process)
    try:
        session.wait_heartbeat(15.0)
    except Exception:
        handle.close()
        raise
    finally:
        pair.release_slave()  # from now on the emulator's end closing reads as LinkLost
    return handle


def open_board(port: str, mavlink: str | None, watchdog_s: float) -> BoardHandle:
    connection = parse_connection(port)
    kind = BoardKind.HITL if connection.kind == "serial" else BoardKind.SITL
    session = BoardSession(open_link(port), kind, watchdog_s=watchdog_s)
    commands = BoardSession(open_link(mavlink), kind, watchdog_s=watchdog_s) if mavlink else session
    return BoardHandle(session, commands, kind, f"{kind.value} on {port}" + (f", commands on {mavlink}" if mavlink else ""))
