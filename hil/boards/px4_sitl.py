"""PX4 SITL started by the bench from a build: a fresh PX4 per run on a free instance, its rootfs (and ULogs)
in the run directory, lockstep over TCP, and the bench's commands on a MAVLink instance of its own, so that PX4's
GCS instance (QGroundControl, UDP 14550) and its offboard/API instance (MAVSDK, MAVROS: UDP 14540) stay free for
whoever else flies or watches.

PX4's posix start-up script sources `px4-rc.mavlink` through PATH ("user defined mavlink streams for instances can
be in PATH", etc/init.d-posix/rcS): the bench puts one first in PATH that sources PX4's own and then starts one more
onboard-mode instance, listening on UDP 14620+N and sending to 14660+N until the bench's first datagram arrives.
PX4 takes the first sender on a UDP instance as its partner for good (mavlink_receiver.cpp), which is why the bench
must not speak on the API instance: a MAVSDK on 14540 would never hear PX4 again.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from functools import partial
from pathlib import Path

from firmware_interface.board import SIMULATED, BoardSession
from firmware_interface.board_dropped_reply import DroppedReplies
from firmware_interface.link import Link, LinkError, TcpServerTransport, open_link
from hil.boards.handle import BoardHandle, abandon_attach
from hil.boards.px4 import Px4Build, Px4Process, claim_instance
from hil.boards.px4.parameters import px4_parameters, sitl_start_parameters, write_sitl_start_parameters
from hil.boards.px4.process import child_setup
from hil.boards.target import BoardPolicy, LinkSettings
from hil.host.process_cpu import threads_at_rest
from hil.scenario.schema import Scenario

SITL_SIMULATOR_PORT = 4560  # PX4 SITL instance N connects to 127.0.0.1:4560+N
SITL_API_PORT = 14540  # where PX4 SITL's offboard/API instance sends (MAVSDK's and MAVROS's default)
SITL_GCS_PORT = 14550  # where PX4 SITL's GCS instance sends (QGroundControl's default)
BENCH_LINK_PORT = 14620  # PX4 SITL instance N listens for the bench on UDP 14620+N (an instance the bench adds)
BENCH_LINK_REMOTE_PORT = 14660  # ... and sends to 14660+N until the bench has spoken (nobody listens there)
RC_MAVLINK = """#!/bin/sh
# Written by hil-bench for one run: PX4's own MAVLink instances, then one for the bench.
. "${{R}}etc/init.d-posix/px4-rc.mavlink"
mavlink start -u $(({port}+px4_instance)) -r 4000000 -m onboard -o $(({remote}+px4_instance))
"""
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
    connect_timeout_s: float | None = None  # to connect, and for each silence while it boots (PX4_START_TIMEOUT_S)

    @property
    def label(self) -> str:
        return f"PX4 SITL from {self.build.root}"

    def policy(self, scenario: Scenario) -> BoardPolicy:
        return SITL_POLICY

    def attach(self, scenario: Scenario, run_dir: Path, settings: LinkSettings) -> BoardHandle:
        settings.ready_to_step()  # PX4 waits for the first HIL_SENSOR from its connection on, 1 s before an error
        claim, listener = claim_instance(_reserve_simulator_port)
        n = claim.number
        try:
            px4 = Px4Process(self.build, claim, run_dir / "px4", run_dir / "px4.log",
                             _environment(run_dir, settings, sitl_start_parameters(scenario, settings.rotors)),
                             preexec=partial(child_setup, n))
        except BaseException:
            listener.close()
            claim.release()
            raise
        handle: BoardHandle | None = None
        try:  # from PX4's start on, whatever stops the attach (a stop signal too) stops PX4
            session = BoardSession(Link(listener, tap=settings.tap), SIMULATED, watchdog_s=settings.watchdog_s,
                                   reversible_motors=settings.reversible_motors, motor_count=settings.motor_count)
            session.watchdog.dropped_replies = DroppedReplies(partial(threads_at_rest, px4.popen.pid))
            handle = BoardHandle(session, session, f"PX4 SITL instance {n} ({self.build.root}), simulator "
                                 f"tcpin:127.0.0.1:{SITL_SIMULATOR_PORT + n}, the bench's commands udpout:127.0.0.1:"
                                 f"{BENCH_LINK_PORT + n}; QGroundControl: udp {SITL_GCS_PORT}, MAVSDK/MAVROS: udp "
                                 f"{SITL_API_PORT + n}", process=px4, params=px4_parameters(scenario, settings.rotors))
            commands = open_link(f"udpout:127.0.0.1:{BENCH_LINK_PORT + n}", tap=settings.tap)
            handle.command_session = BoardSession(commands, SIMULATED, watchdog_s=settings.watchdog_s)
            session.wait_heartbeat(self.connect_timeout_s or PX4_START_TIMEOUT_S,
                                   hint=f"PX4 did not connect; see {px4.log_path}",
                                   still_starting=px4.check_starting)
        except BaseException:
            abandon_attach(handle, px4, listener)
            raise
        return handle


def _environment(run_dir: Path, settings: LinkSettings, params: dict[str, float | int]) -> dict[str, str]:
    """PX4's environment for the run: the airframe, no GUI, the bench's px4-rc.mavlink and px4-rc.params (`params`:
    the plant's rotors, the scenario's parameters) first in PATH, and PX4_SIM_SPEED_FACTOR when the run is paced
    faster than the wall clock (PX4 then lengthens its link-loss timeouts, which an outside pilot's wall-clock
    messages would otherwise break)."""
    speed_factor = settings.speed_factor
    scripts = (run_dir / "px4-scripts").resolve()
    scripts.mkdir(parents=True, exist_ok=True)
    (scripts / "px4-rc.mavlink").write_text(RC_MAVLINK.format(port=BENCH_LINK_PORT, remote=BENCH_LINK_REMOTE_PORT))
    write_sitl_start_parameters(scripts, params)
    env = {"PX4_SYS_AUTOSTART": "10016", "PX4_SIM_MODEL": "none_iris", "HEADLESS": "1",
           "PATH": f"{scripts}{os.pathsep}{os.environ.get('PATH', '')}"}
    if speed_factor != 1.0:
        env["PX4_SIM_SPEED_FACTOR"] = f"{speed_factor:g}"
    return env
