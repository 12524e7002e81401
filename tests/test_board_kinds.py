"""Every registered board kind, through the registry as a user names it: its policy holds together, and a badly named
board is one line. The emulator kind attaches and leaves nothing behind."""

from __future__ import annotations

import os
import socket
import subprocess
from pathlib import Path

import pytest

from firmware_interface.board import SIMULATED, BoardSession
from firmware_interface.link import Link, open_pty_pair, parse_connection
from hil.boards import emulator
from hil.boards.emulator import EmulatorProcess
from hil.boards.handle import BoardHandle
from hil.boards.registry import KINDS, BoardOptions, BoardSpecError, board_target
from hil.boards.target import LinkSettings
from hil.scenario.loader import load_scenario

ROOT = Path(__file__).resolve().parent.parent
KNOWN_KINDS = {"emulator", "px4_sitl", "px4_hitl", "attached"}


@pytest.fixture
def fake_px4_build(tmp_path) -> Path:
    """What a PX4 build looks like from outside (bin/px4, etc/init.d-posix/rcS): enough to name one."""
    (tmp_path / "bin").mkdir()
    (tmp_path / "bin" / "px4").write_text("#!/bin/sh\n")
    os.chmod(tmp_path / "bin" / "px4", 0o755)
    (tmp_path / "etc" / "init.d-posix").mkdir(parents=True)
    (tmp_path / "etc" / "init.d-posix" / "rcS").write_text("")
    return tmp_path


def example_specs(build: Path) -> dict[str, list[str]]:
    return {"emulator": ["emulator"], "px4": [f"px4:{build}"], "px4-hitl": [f"px4-hitl:{build}"],
            "port": ["port:/dev/ttyACM0", "port:tcpin:127.0.0.1:4560"]}


def test_every_registered_kind_has_an_example_here(fake_px4_build):
    assert set(example_specs(fake_px4_build)) == set(KINDS)


def test_each_kind_has_a_policy_that_holds_together(fake_px4_build):
    scenario = load_scenario(ROOT / "scenarios" / "hover.yaml")
    for specs in example_specs(fake_px4_build).values():
        for spec in specs:
            target = board_target(spec)
            policy = target.policy(scenario)
            assert target.label and policy.autopilot and policy.kind in KNOWN_KINDS, spec
            if policy.wall_clock:  # a board on its own clock is a real board's path: its EKF never gets the truth
                assert policy.ground_truth == "none", spec
            assert policy.px4 == (policy.kind != "emulator"), spec
            if policy.px4:  # PX4 streams ~400 messages a second on a link nobody else reads
                assert policy.stops_unread_streams, spec
            for endpoint in policy.default_gcs:
                parse_connection(endpoint)


def test_every_kind_takes_the_connect_timeout(fake_px4_build):
    """--connect-timeout: how long any board has to speak first (and a lockstep one, each silence while it boots)."""
    for specs in example_specs(fake_px4_build).values():
        for spec in specs:
            assert board_target(spec, BoardOptions(connect_timeout_s=7.5)).connect_timeout_s == 7.5, spec


def test_a_port_is_a_pixhawk_when_serial_and_a_px4_sitl_started_by_hand_otherwise():
    scenario = load_scenario(ROOT / "scenarios" / "hover.yaml")
    serial = board_target("port:/dev/ttyACM0", BoardOptions(baud=57600)).policy(scenario)
    sitl = board_target("port:tcpin:127.0.0.1:4560", BoardOptions(mavlink="udpout:127.0.0.1:14580")).policy(scenario)
    assert (serial.wall_clock, serial.ground_truth) == (True, "none")
    assert (sitl.wall_clock, sitl.ground_truth) == (False, "for_log")


def test_the_emulator_flies_on_the_truth_only_when_the_scenario_says_so():
    hover = load_scenario(ROOT / "scenarios" / "hover.yaml")
    helix = load_scenario(ROOT / "scenarios" / "paper_helix.yaml")  # state_source: truth (the paper's §4)
    assert board_target("emulator").policy(hover).ground_truth == "none"
    assert helix.board.state_source == "truth"
    assert board_target("emulator").policy(helix).ground_truth == "to_fly"


@pytest.mark.parametrize(("spec", "options", "said"), [
    ("jmavsim", BoardOptions(), "unknown board kind 'jmavsim' (expected emulator, px4:..., px4-hitl:..., port:...)"),
    ("emulator:fast", BoardOptions(), "the emulator takes no argument"),
    ("px4:/no/such/dir", BoardOptions(named_by="--px4"), "--px4 /no/such/dir: no such directory"),
    ("port:bogus", BoardOptions(named_by="--port"), "--port bogus: unsupported connection"),
    ("port:tcpin:127.0.0.1:4560", BoardOptions(mavlink="udpout:nowhere"), "--mavlink udpout:nowhere:"),
])
def test_a_board_named_wrongly_is_one_line_naming_what_is_wrong(spec, options, said):
    with pytest.raises(BoardSpecError) as caught:
        board_target(spec, options)
    message = str(caught.value)
    assert said in message and "\n" not in message


@pytest.mark.slow
def test_the_emulator_attaches_speaks_and_leaves_nothing_running(tmp_path):
    scenario = load_scenario(ROOT / "scenarios" / "hover.yaml")
    handle = board_target("emulator").attach(scenario, tmp_path, LinkSettings(watchdog_s=2.0))
    try:
        assert handle.hil_session.report.info is not None and handle.realtime_pids()
        process = handle.process
    finally:
        handle.close()
    assert process is not None and process.popen.poll() is not None


def test_an_attach_stopped_once_the_emulator_has_started_stops_the_emulator(tmp_path, monkeypatch):
    """A stop signal lands as a KeyboardInterrupt wherever the bench is: here, while the emulator's session is made,
    after its process started (seen in CI: a SIGTERM 0.2 s into a run left the emulator running)."""
    started = []

    def start(args: list[str], log) -> object:
        started.append(real_start(args, log))
        return started[-1]

    def stopped_here(*_: object) -> BoardSession:
        raise KeyboardInterrupt("SIGTERM")

    real_start = emulator.start_emulator
    monkeypatch.setattr(emulator, "start_emulator", start)
    monkeypatch.setattr(emulator, "emulator_session", stopped_here)
    with pytest.raises(KeyboardInterrupt):
        board_target("emulator").attach(load_scenario(ROOT / "scenarios" / "hover.yaml"), tmp_path, LinkSettings())
    (popen,) = started
    assert popen.poll() is not None  # stopped and reaped before the interrupt went on


class NotReady(Exception):
    """Raised by a run that is not ready to step, to see what a board kind had started before it asked."""


@pytest.mark.parametrize("spec", ["px4", "sitl_port"])
def test_a_lockstep_px4_is_started_or_listened_for_only_once_the_bench_can_send_its_first_step(
        spec, fake_px4_build, tmp_path):
    """PX4 SITL counts from its connection to the first HIL_SENSOR (after 1 s it logs an error, and three flights on
    two cores made it wait that long): the kinds it connects to ask the run's `ready_to_step` before they start PX4
    (its log is written from its start) or listen on the simulator port a PX4 started by hand connects to."""
    port = free_tcp_port()
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    name, started = {"px4": (f"px4:{fake_px4_build}", (run_dir / "px4.log").exists),
                     "sitl_port": (f"port:tcpin:127.0.0.1:{port}", lambda: listening(port))}[spec]
    asked: list[bool] = []

    def ready_to_step() -> None:
        asked.append(started())
        raise NotReady

    with pytest.raises(NotReady):
        board_target(name).attach(load_scenario(ROOT / "scenarios" / "hover.yaml"), run_dir,
                                  LinkSettings(ready_to_step=ready_to_step))
    assert asked == [False] and not started()


def free_tcp_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def listening(port: int) -> bool:
    with socket.socket() as s:
        return s.connect_ex(("127.0.0.1", port)) == 0


def test_a_board_failure_waits_for_the_dying_process_to_give_its_exit_as_the_cause(tmp_path):
    """A killed board resets its links before its exit is posted: the note waits for the exit, within `wait_s`."""
    pair = open_pty_pair()
    session = BoardSession(Link(pair.master), SIMULATED)
    popen = subprocess.Popen(["sh", "-c", "sleep 0.3; exit 3"])
    handle = BoardHandle(session, session, "a board process", EmulatorProcess(popen, tmp_path / "emulator.log"))
    try:
        assert handle.exit_note() is None  # still running: the check does not wait by default
        assert handle.exit_note(wait_s=5.0) == f"the emulator exited with code 3 (see {tmp_path / 'emulator.log'})"
    finally:
        popen.kill()
        popen.wait()
        handle.close()  # the process is gone: closes the link
        pair.release_slave()
