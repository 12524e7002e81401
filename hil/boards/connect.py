"""Attach the bench to a board: the built-in emulator on a fresh pty, PX4 started by the bench
(SITL in lockstep, or PX4's HITL code path on a pty), or a board the user started or plugged in."""

from __future__ import annotations

import subprocess
import sys
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Protocol

import yaml

from firmware_interface.board import BoardError, BoardKind, BoardSession
from firmware_interface.link import (
    FrameTap,
    Link,
    LinkError,
    TcpServerTransport,
    open_link,
    open_pty_pair,
    parse_connection,
)
from hil.boards.gcs_relay import GcsBridge
from hil.boards.px4 import Px4Build, Px4Process, claim_instance
from hil.boards.px4.hitl_startup import write_hitl_startup
from hil.host.lifetime import die_with_parent
from hil.host.process_cpu import cpu_seconds
from hil.host.rt_priority import board_on_its_own_core
from hil.scenario.schema import Scenario
from hil.sensors.config import GPS_PROFILES, resolve

SITL_SIMULATOR_PORT = 4560  # PX4 SITL instance N connects to 127.0.0.1:4560+N
SITL_OFFBOARD_PORT = 14580  # PX4 SITL instance N listens for offboard/API MAVLink on UDP 14580+N
SITL_GCS_PORT = 14550  # where PX4 SITL's GCS instance sends (QGroundControl's default)
PX4_START_TIMEOUT_S = 30.0
MANUAL_SITL_WAIT_S = 60.0  # a PX4 started by hand after the bench has this long to connect
SERIAL_WAIT_S = 10.0  # a Pixhawk sends its heartbeat at 1 Hz from boot
# the emulator's first heartbeat follows its flight code's compilation: ~0.2 s from the cache, ~8 s the first
# time on a machine, longer when runs start side by side; a process that dies is reported at once
EMULATOR_START_S = 60.0
SITL_HINT = ("is PX4 SITL running? Start it (in PX4-Autopilot: make px4_sitl none_iris; or let the bench start it with "
             "--px4 DIR); PX4 connects to 127.0.0.1:4560+instance")


class BoardProcess(Protocol):
    popen: subprocess.Popen[bytes]

    def stop(self) -> None: ...

    def exit_note(self) -> str | None: ...


@dataclass
class EmulatorProcess:
    popen: subprocess.Popen[bytes]
    log_path: Path

    def exit_note(self) -> str | None:
        code = self.popen.poll()
        return None if code is None else f"the emulator exited with code {code} (see {self.log_path})"

    def stop(self) -> None:
        if self.popen.poll() is None:
            self.popen.terminate()
            try:
                self.popen.wait(2.0)
            except subprocess.TimeoutExpired:
                self.popen.kill()
                self.popen.wait()


@dataclass
class BoardHandle:
    session: BoardSession  # the HIL link (sensors out, actuators in)
    commands: BoardSession  # heartbeat, arming, offboard, setpoints: the same session unless --mavlink
    kind: BoardKind
    description: str
    flight_code: str  # what flies: the emulator's controller, or PX4's own
    process: BoardProcess | None = None
    params: dict[str, float] = field(default_factory=dict)  # set on the board before arming
    gcs: GcsBridge | None = None  # relays the board's traffic to ground stations and back

    @property
    def sessions(self) -> list[BoardSession]:
        """Each link to the board once: the HIL link, and the command link when it is a separate one."""
        return [self.session] if self.commands is self.session else [self.session, self.commands]

    def relay_to(self, gcs: GcsBridge) -> None:
        self.gcs = gcs
        for session in self.sessions:
            session.relay = []

    def realtime_pids(self) -> list[int]:
        """The board's processes a paced run raises to real-time priority with the bench: the emulator's
        (a PX4 keeps the scheduling it gives its own tasks)."""
        return [self.process.popen.pid] if isinstance(self.process, EmulatorProcess) else []

    def cpu_s(self) -> float | None:
        """CPU seconds the board's process has used, when the bench started it (None for a board attached)."""
        return cpu_seconds(self.process.popen.pid) if self.process is not None else None

    def exit_note(self) -> str | None:
        """Why the board's process ended, when the bench started it and it is gone (a board failure's cause)."""
        return self.process.exit_note() if self.process is not None else None

    def close(self) -> None:
        """Stop what the bench started (PX4 included: nothing is left running), then close the links."""
        if self.process is not None:
            self.process.stop()
        for session in self.sessions:
            session.link.close()
        if self.gcs is not None:
            self.gcs.close()


def px4_parameters(scenario: Scenario) -> dict[str, float]:
    """What a PX4 the bench started is told about the simulated vehicle, as a user configures a real one:
    EKF2_GPS_DELAY (ms) is the receiver's delay (PX4 SITL's own default of 10 ms assumes a delay-free
    simulator GPS)."""
    gps = resolve(GPS_PROFILES, scenario.sensors.gps.profile, scenario.sensors.gps.overrides)
    return {"EKF2_GPS_DELAY": round(gps.delay_s * 1000.0, 3)}


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


def start_emulator(scenario: Scenario, run_dir: Path, watchdog_s: float, tap: FrameTap | None = None) -> BoardHandle:
    config_path = run_dir / "emulator.yaml"
    config_path.write_text(yaml.safe_dump(emulator_config(scenario), sort_keys=False))
    pair = open_pty_pair()
    log = open(run_dir / "emulator.log", "wb")  # noqa: SIM115 - owned by the child process
    popen = subprocess.Popen([sys.executable, "-m", "firmware_interface.emulator", "--port", pair.slave_path,
                              "--config", str(config_path)], stdout=log, stderr=log,
                             start_new_session=True)  # a terminal Ctrl-C stops the bench, which stops it
    session = BoardSession(Link(pair.master, tap=tap), BoardKind.EMULATOR, watchdog_s=watchdog_s)
    handle = BoardHandle(session, session, BoardKind.EMULATOR, f"emulator on {pair.slave_path}",
                         f"emulator, controller {scenario.board.controller}",
                         EmulatorProcess(popen, run_dir / "emulator.log"))
    def still_starting() -> None:
        note = handle.exit_note()
        if note is not None:
            raise BoardError(f"{note} before its first heartbeat")

    try:
        session.wait_heartbeat(EMULATOR_START_S, hint=f"the emulator did not start; see {run_dir / 'emulator.log'}",
                               still_starting=still_starting)
    except BaseException:
        handle.close()
        raise
    finally:
        pair.release_slave()  # from now on the emulator's end closing reads as LinkLost
    return handle


def open_board(port: str, mavlink: str | None, watchdog_s: float, wait_s: float | None = None,
               tap: FrameTap | None = None, baud: int | None = None) -> BoardHandle:
    """A board the user attached: a Pixhawk on a serial port (HITL), or a PX4 SITL started by hand (which
    may be started after the bench: it gets `wait_s`, by default MANUAL_SITL_WAIT_S, to connect)."""
    connection = parse_connection(port, baud)
    kind = BoardKind.HITL if connection.kind == "serial" else BoardKind.SITL
    session = BoardSession(open_link(port, tap=tap, baud=baud), kind, watchdog_s=watchdog_s)
    commands = BoardSession(open_link(mavlink, tap=tap), kind, watchdog_s=watchdog_s) if mavlink else session
    description = f"{kind.value} on {port}" + (f", commands on {mavlink}" if mavlink else "")
    handle = BoardHandle(session, commands, kind, description, "the board's own (PX4)")
    try:
        if kind is BoardKind.SITL:
            session.wait_heartbeat(wait_s or MANUAL_SITL_WAIT_S, hint=SITL_HINT)
        else:
            session.wait_heartbeat(wait_s or SERIAL_WAIT_S)
    except BaseException:
        handle.close()
        raise
    return handle


def _started_by_us(px4: Px4Process) -> None:
    code = px4.exit_code()
    if code is not None:
        raise BoardError(f"PX4 exited during start-up (code {code}): {px4.log_tail() or 'no output'} "
                         f"(console: {px4.log_path})")


def _reserve_simulator_port(instance: int) -> TcpServerTransport | None:
    try:
        return TcpServerTransport("127.0.0.1", SITL_SIMULATOR_PORT + instance)
    except LinkError:
        return None


def start_px4_sitl(build: Px4Build, run_dir: Path, watchdog_s: float, tap: FrameTap | None = None) -> BoardHandle:
    """PX4 SITL from `build` on a free instance, its rootfs (and ULogs) in `run_dir/px4`, lockstep over TCP."""
    claim, listener = claim_instance(_reserve_simulator_port)
    n = claim.number
    try:
        px4 = Px4Process(build, claim, run_dir / "px4", run_dir / "px4.log",
                         {"PX4_SYS_AUTOSTART": "10016", "PX4_SIM_MODEL": "none_iris", "HEADLESS": "1"},
                         preexec=partial(_px4_child_setup, n))
    except BaseException:
        listener.close()
        claim.release()
        raise
    session = BoardSession(Link(listener, tap=tap), BoardKind.SITL, watchdog_s=watchdog_s)
    commands = BoardSession(open_link(f"udpout:127.0.0.1:{SITL_OFFBOARD_PORT + n}", tap=tap), BoardKind.SITL,
                            watchdog_s=watchdog_s)
    handle = BoardHandle(session, commands, BoardKind.SITL,
                         f"PX4 SITL instance {n} ({build.root}), simulator tcpin:127.0.0.1:{SITL_SIMULATOR_PORT + n}, "
                         f"commands udpout:127.0.0.1:{SITL_OFFBOARD_PORT + n}, QGroundControl: udp {SITL_GCS_PORT}",
                         "PX4 (its own estimator and controllers)", px4)
    try:
        session.wait_heartbeat(PX4_START_TIMEOUT_S, hint=f"PX4 did not connect; see {px4.log_path}",
                               still_starting=lambda: _started_by_us(px4))
    except BaseException:
        handle.close()
        raise
    return handle


def _px4_child_setup(instance: int) -> None:
    die_with_parent()
    board_on_its_own_core(instance)


def start_px4_hitl(build: Px4Build, run_dir: Path, watchdog_s: float, tap: FrameTap | None = None) -> BoardHandle:
    """PX4's HITL code path from `build` (a px4_sitl_nolockstep build) with its HIL link on a pty: the
    bench then flies the same serial path as with a Pixhawk on /dev/ttyACM0."""
    pair = open_pty_pair()
    claim, _ = claim_instance(lambda n: n)
    try:
        script = write_hitl_startup(run_dir.resolve() / "px4-hitl.rcS", pair.slave_path)  # PX4 runs elsewhere
        px4 = Px4Process(build, claim, run_dir / "px4", run_dir / "px4.log", {"HEADLESS": "1"},
                         extra_args=("-s", str(script)), preexec=partial(_px4_child_setup, claim.number))
    except BaseException:
        claim.release()
        pair.master.close()
        pair.release_slave()
        raise
    session = BoardSession(Link(pair.master, tap=tap), BoardKind.HITL, watchdog_s=watchdog_s)
    handle = BoardHandle(session, session, BoardKind.HITL,
                         f"PX4 HITL rehearsal, instance {claim.number} ({build.root}) on {pair.slave_path}",
                         "PX4 (its own estimator and controllers)", px4)
    try:
        session.wait_heartbeat(PX4_START_TIMEOUT_S, hint=f"is {build.root} a px4_sitl_nolockstep build? "
                               f"see {px4.log_path}", still_starting=lambda: _started_by_us(px4))
    except BaseException:
        handle.close()
        raise
    finally:
        pair.release_slave()  # PX4 holds its end now
    return handle
