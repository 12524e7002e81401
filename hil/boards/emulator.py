"""The built-in emulator: the software flight controller in its own process on a fresh pty, in lockstep."""

from __future__ import annotations

import functools
import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

import yaml

from firmware_interface.board import SIMULATED, BoardError, BoardSession
from firmware_interface.board_starvation import CpuStarvation
from firmware_interface.forkserver import FORKSERVER_ENV
from firmware_interface.link import Link, open_pty_pair
from firmware_interface.link.transports import FdTransport
from hil.boards.forked_emulator import ForkedEmulator, fork_emulator
from hil.boards.gcs_relay import DEFAULT_GCS
from hil.boards.handle import BoardHandle, ChildProcess, abandon_attach
from hil.boards.target import BoardPolicy, GroundTruthUse, LinkSettings
from hil.host.process_cpu import cpu_schedule, scheduler_state
from hil.scenario.plant import RotorGeometry
from hil.scenario.schema import Scenario
from hil.sensors.config import GPS_PROFILES, resolve

# the emulator's first heartbeat follows its flight code's compilation: ~0.2 s from the cache, ~8 s the first
# time on a machine, longer when runs start side by side; a process that dies is reported at once
EMULATOR_START_S = 60.0


def emulator_session(master: FdTransport, settings: LinkSettings) -> BoardSession:
    """The bench's side of an emulator's pty. The emulator answers every HIL_SENSOR from the first on (its heartbeat
    comes once its flight code is loaded), so its first replies are waited for as long as any later one: the few
    ms a booting PX4 SITL gets let a loaded machine shift them by steps, and the recording with them
    (manual_control_loss, three test files at a time)."""
    return BoardSession(Link(master, tap=settings.tap), SIMULATED, watchdog_s=settings.watchdog_s,
                        free_run_wait_s=settings.watchdog_s, reversible_motors=settings.reversible_motors,
                        motor_count=settings.motor_count)


@dataclass
class EmulatorProcess:
    popen: ChildProcess
    log_path: Path
    paced_with_bench = True  # our own process: a paced run raises it to real-time priority with the bench

    def exit_note(self) -> str | None:
        code = self.popen.poll()
        return None if code is None else f"the emulator exited with code {code} (see {self.log_path})"

    def console_note(self) -> str | None:
        """None: a live emulator's silence is told by its scheduler state (`board_watchdog`), its log is beside."""
        return None

    def stop(self) -> None:
        if self.popen.poll() is None:
            self.popen.terminate()
            try:
                self.popen.wait(2.0)
            except subprocess.TimeoutExpired:
                self.popen.kill()
                self.popen.wait()


def start_emulator(args: list[str], log: BinaryIO) -> ChildProcess:
    """The emulator with `args`, writing to `log`, in a session of its own (a terminal's Ctrl-C stops the bench,
    which stops it): forked by the warm fork server `FORKSERVER_ENV` names, when one answers there; otherwise a
    fresh process."""
    server = os.environ.get(FORKSERVER_ENV)
    if server:
        try:
            return fork_emulator(server, args, log.fileno())
        except OSError as exc:
            log.write(f"the emulator fork server at {server} did not answer ({exc}); started afresh\n".encode())
            log.flush()
    return subprocess.Popen([sys.executable, "-m", "firmware_interface.emulator", *args], stdout=log, stderr=log,
                            start_new_session=True)


def emulator_config(scenario: Scenario, rotors: RotorGeometry | None = None) -> dict:
    """What the emulator is told: the scenario's board settings and PX4 parameters, EKF2_GPS_DELAY set to the
    receiver's delay, as a
    user would set the parameter for the GPS on the vehicle, and the plant's rotors for its mixer, as a user sets
    PX4's control allocation for the frame (unless the scenario's board.config gives the mixer rotors of its own)."""
    board = scenario.board
    gps = resolve(GPS_PROFILES, scenario.sensors.gps.profile, scenario.sensors.gps.overrides)
    config = {"airframe": board.airframe or scenario.vehicle.preset, "controller": board.controller,
              "state_source": board.state_source, **board.config}
    if board.params:  # PX4's parameters for every board (board.params), with the emulator's own (board.config)
        config["params"] = {**board.params, **config.get("params", {})}
    if not scenario.faults.link:  # lockstep: a bench the machine stalls holds the flight's time too (a CI run's
        config.setdefault("failsafe_s", None)  # bench stalled 0.6 s between two steps; the emulator disarmed in flight)
    estimator = dict(config.get("estimator", {}))
    estimator.setdefault("gps_delay_s", gps.delay_s)
    config["estimator"] = estimator
    if rotors is not None:
        vehicle = dict(config.get("vehicle", {}))
        placed = zip(rotors.positions_frd_m.tolist(), rotors.ccw, strict=True)
        vehicle.setdefault("rotors", [{"position_frd_m": xyz, "spin": "ccw" if ccw else "cw"} for xyz, ccw in placed])
        config["vehicle"] = vehicle
    return config


@dataclass(frozen=True)
class EmulatorTarget:
    label = "emulator"
    connect_timeout_s: float | None = None  # to its first heartbeat, and each silence while it boots (EMULATOR_START_S)

    def policy(self, scenario: Scenario) -> BoardPolicy:
        truth: GroundTruthUse = "to_fly" if scenario.board.state_source == "truth" else "none"
        return BoardPolicy("emulator", f"emulator, controller {scenario.board.controller}", wall_clock=False,
                           ground_truth=truth, px4=False, default_gcs=(DEFAULT_GCS,),
                           stops_unread_streams=False)  # it streams only what the bench reads

    def attach(self, scenario: Scenario, run_dir: Path, settings: LinkSettings) -> BoardHandle:
        config_path = run_dir / "emulator.yaml"
        config_path.write_text(yaml.safe_dump(emulator_config(scenario, settings.rotors), sort_keys=False))
        pair = open_pty_pair()
        # one boot heartbeat: the bench holds the pty from before the emulator starts and waits for it; more, on the
        # wall clock, could land after the pre-step drain in a recorded step
        spin = ["--spin-wait"] if settings.spin_wait else []
        with open(run_dir / "emulator.log", "wb") as log:
            popen = start_emulator(["--port", pair.slave_path, "--config", str(config_path), "--one-boot-heartbeat",
                                    *spin], log)
        process = EmulatorProcess(popen, run_dir / "emulator.log")

        def still_starting() -> None:
            note = process.exit_note()
            if note is not None:
                raise BoardError(f"{note} before its first heartbeat")

        handle: BoardHandle | None = None
        try:  # from the emulator's start on, whatever stops the attach (a stop signal too) stops the emulator
            session = emulator_session(pair.master, settings)
            warm = " (forked by the warm server)" if isinstance(popen, ForkedEmulator) else ""
            handle = BoardHandle(session, session, f"emulator on {pair.slave_path}{warm}", process)
            # one thread serves the link: its state is the board's (runnable and silent: waiting for a CPU)
            state = session.watchdog.process_state = functools.partial(scheduler_state, popen.pid)
            session.starvation = CpuStarvation(functools.partial(cpu_schedule, popen.pid), state)
            session.wait_heartbeat(self.connect_timeout_s or EMULATOR_START_S, still_starting=still_starting,
                                   hint=f"the emulator did not start; see {run_dir / 'emulator.log'}")
        except BaseException:
            abandon_attach(handle, process, pair.master)
            raise
        finally:
            pair.release_slave()  # from now on the emulator's end closing reads as LinkLost
        return handle
