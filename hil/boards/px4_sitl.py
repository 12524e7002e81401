"""PX4 SITL started by the bench from a build: a fresh PX4 per run on a free instance, its rootfs (and ULogs)
in the run directory, lockstep over TCP, commands on its offboard/API UDP port."""

from __future__ import annotations

import os
from dataclasses import dataclass
from functools import partial
from pathlib import Path

from firmware_interface.board import SIMULATED, BoardSession
from firmware_interface.link import Link, LinkError, TcpServerTransport, open_link
from hil.boards.handle import BoardHandle
from hil.boards.px4 import Px4Build, Px4Process, claim_instance
from hil.boards.px4.parameters import px4_parameters, write_sitl_rotor_parameters
from hil.boards.px4.process import child_setup
from hil.boards.target import BoardPolicy, LinkSettings
from hil.scenario.schema import Scenario

SITL_SIMULATOR_PORT = 4560  # PX4 SITL instance N connects to 127.0.0.1:4560+N
SITL_OFFBOARD_PORT = 14580  # PX4 SITL instance N listens for offboard/API MAVLink on UDP 14580+N
SITL_GCS_PORT = 14550  # where PX4 SITL's GCS instance sends (QGroundControl's default)
PX4_START_TIMEOUT_S = 30.0
SITL_POLICY = BoardPolicy("px4_sitl", "PX4 (its own estimator and controllers)",
                          wall_clock=False, ground_truth="for_log", px4=True, default_gcs=(),
                          stops_unread_streams=True)  # PX4 SITL has its own GCS port: QGC uses it directly


def _reserve_simulator_port(instance: int) -> TcpServerTransport | None:
    try:
        return TcpServerTransport("127.0.0.1", SITL_SIMULATOR_PORT + instance)
    except LinkError:
        return None


@dataclass(frozen=True)
class Px4SitlTarget:
    build: Px4Build

    @property
    def label(self) -> str:
        return f"PX4 SITL from {self.build.root}"

    def policy(self, scenario: Scenario) -> BoardPolicy:
        return SITL_POLICY

    def attach(self, scenario: Scenario, run_dir: Path, settings: LinkSettings) -> BoardHandle:
        claim, listener = claim_instance(_reserve_simulator_port)
        n = claim.number
        try:
            folder = write_sitl_rotor_parameters(run_dir.resolve(), settings.rotors).parent  # first on PX4's PATH
            px4 = Px4Process(self.build, claim, run_dir / "px4", run_dir / "px4.log",
                             {"PX4_SYS_AUTOSTART": "10016", "PX4_SIM_MODEL": "none_iris", "HEADLESS": "1",
                              "PATH": f"{folder}{os.pathsep}{os.environ.get('PATH', '')}"},
                             preexec=partial(child_setup, n))
        except BaseException:
            listener.close()
            claim.release()
            raise
        session = BoardSession(Link(listener, tap=settings.tap), SIMULATED, watchdog_s=settings.watchdog_s,
                               reversible_motors=settings.reversible_motors,
                               motor_count=settings.motor_count)
        handle = BoardHandle(session, session, f"PX4 SITL instance {n} ({self.build.root}), simulator "
                             f"tcpin:127.0.0.1:{SITL_SIMULATOR_PORT + n}, commands udpout:127.0.0.1:"
                             f"{SITL_OFFBOARD_PORT + n}, QGroundControl: udp {SITL_GCS_PORT}",
                             process=px4, params=px4_parameters(scenario, settings.rotors))
        try:
            commands = open_link(f"udpout:127.0.0.1:{SITL_OFFBOARD_PORT + n}", tap=settings.tap)
            handle.command_session = BoardSession(commands, SIMULATED, watchdog_s=settings.watchdog_s)
            session.wait_heartbeat(PX4_START_TIMEOUT_S, hint=f"PX4 did not connect; see {px4.log_path}",
                                   still_starting=px4.check_starting)
        except BaseException:
            handle.close()
            raise
        return handle
