"""The emulator fork server (firmware_interface/emulator/forkserver.py, hil/boards/forked_emulator.py): a forked
emulator is the server's child and flies what a fresh process flies, bit for bit; its end and exit code reach the
bench as `subprocess.Popen` gives a child's; a server that does not answer costs nothing but the warm start; and
the server ends with whoever started it."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time

import psutil
import pytest

from firmware_interface.forkserver import FORKSERVER_ENV
from firmware_interface.link import open_pty_pair
from hil.boards.emulator import start_emulator
from hil.boards.forked_emulator import ForkedEmulator, fork_emulator
from hil.run.runner import RunOptions, run_scenario
from hil.scenario.loader import load_scenario
from tests.support.cli_runs import ROOT
from tests.support.emulator_process import EmulatorWithItsProcess
from tests.support.recording_digest import simulated_digest


@pytest.mark.e2e
def test_a_forked_emulator_is_the_servers_child_and_flies_what_a_fresh_one_flies(tmp_path, monkeypatch):
    scenario_path = tmp_path / "hold.yaml"
    scenario_path.write_text("name: hold\nduration_s: 1\nseed: 5\nend: disarm\n"
                             "reference: {type: hover, altitude_m: 2}\n")
    scenario = load_scenario(scenario_path)
    server = os.environ[FORKSERVER_ENV]
    parents: dict[str, list[str]] = {}
    digests = {}
    for label in ("fresh", "forked"):
        if label == "fresh":
            monkeypatch.delenv(FORKSERVER_ENV)
        else:
            monkeypatch.setenv(FORKSERVER_ENV, server)
        board = EmulatorWithItsProcess(lambda pid, label=label: parents.setdefault(
            label, psutil.Process(psutil.Process(pid).ppid()).cmdline()))
        outcome = run_scenario(scenario, RunOptions(board=board, runs_root=tmp_path / label, telemetry=None, gcs=[]))
        assert outcome.exit_code == 0, outcome.reason
        digests[label] = simulated_digest(outcome.run_dir)
    assert parents["fresh"] == psutil.Process().cmdline()  # the bench's own child
    assert parents["forked"][-2:] == ["firmware_interface.emulator.forkserver", server]
    assert digests["forked"] == digests["fresh"]


def test_a_forked_emulators_exit_code_reaches_the_bench_as_a_childs_would(tmp_path):
    """As `subprocess.Popen.returncode`: the emulator's own code (2: a port it cannot open, its message in its
    log), 0 when SIGTERM stops it, -9 when SIGKILL does."""
    server = os.environ[FORKSERVER_ENV]
    with open(tmp_path / "bad.log", "wb") as log:
        bad_port = fork_emulator(server, ["--port", str(tmp_path / "no-such-port")], log.fileno())
    assert bad_port.wait(30) == 2 and bad_port.poll() == 2
    assert "hil emulate:" in (tmp_path / "bad.log").read_text()
    for signum, code in ((signal.SIGTERM, 0), (signal.SIGKILL, -signal.SIGKILL)):
        pair = open_pty_pair()
        with open(tmp_path / f"{signum}.log", "wb") as log:
            emulator = fork_emulator(server, ["--port", pair.slave_path, "--one-boot-heartbeat"], log.fileno())
        assert pair.master.read(30.0)  # its boot heartbeat: flying code loaded, waiting for frames
        assert emulator.poll() is None
        with pytest.raises(subprocess.TimeoutExpired):
            emulator.wait(0.2)
        emulator.terminate() if signum == signal.SIGTERM else emulator.kill()
        assert emulator.wait(10) == code
        assert not psutil.pid_exists(emulator.pid) or psutil.Process(emulator.pid).status() == psutil.STATUS_ZOMBIE
        pair.master.close()
        pair.release_slave()


def test_with_no_server_answering_the_emulator_starts_afresh_and_its_log_says_why(tmp_path, monkeypatch):
    monkeypatch.setenv(FORKSERVER_ENV, str(tmp_path / "nobody.sock"))
    pair = open_pty_pair()
    with open(tmp_path / "emulator.log", "wb") as log:
        process = start_emulator(["--port", pair.slave_path, "--one-boot-heartbeat"], log)
    try:
        assert isinstance(process, subprocess.Popen) and not isinstance(process, ForkedEmulator)
        assert pair.master.read(60.0)
        assert psutil.Process(process.pid).ppid() == os.getpid()
    finally:
        process.terminate()
        process.wait(10)
        pair.master.close()
        pair.release_slave()
    first_line = (tmp_path / "emulator.log").read_text().splitlines()[0]
    assert first_line.startswith(f"the emulator fork server at {tmp_path / 'nobody.sock'} did not answer")


def test_the_server_ends_with_whoever_started_it_even_killed(tmp_path):
    """Its starter SIGKILLed (no cleanup ran): the server sees its standard input end and goes."""
    starter = subprocess.Popen([sys.executable, "-c", textwrap.dedent("""
        import os, sys, time
        from hil.boards.forked_emulator import emulator_forkserver
        with emulator_forkserver() as path:
            print(path, flush=True)
            time.sleep(600)
        """)], cwd=ROOT, stdout=subprocess.PIPE, text=True)
    assert starter.stdout is not None
    path = starter.stdout.readline().strip()
    (server,) = [p for p in psutil.Process(starter.pid).children() if path in p.cmdline()]
    starter.kill()
    starter.wait()
    deadline = time.monotonic() + 10
    while server.is_running() and server.status() != psutil.STATUS_ZOMBIE and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not server.is_running() or server.status() == psutil.STATUS_ZOMBIE


@pytest.mark.e2e
def test_a_sweep_worker_flies_its_samples_on_emulators_from_its_own_server_gone_with_it(tmp_path):
    """A worker process with no server named (as a user's `hil sweep` starts one) starts one with its first
    sample, flies the next on it too, and leaves neither the server nor its directory behind when it exits."""
    worker = textwrap.dedent(f"""
        import os, pathlib, sys
        from hil.sweep.execute import SampleTask, fly_sample
        scenario = "name: hold\\nduration_s: 1\\nseed: 5\\nend: disarm\\nreference: {{type: hover, altitude_m: 2}}\\n"
        for index in (0, 1):
            result = fly_sample(SampleTask(index, scenario, str(pathlib.Path({str(tmp_path)!r}) / str(index))))
            assert result["exit_code"] == 0, result
            print((pathlib.Path(result["run_dir"]) / "summary.txt").read_text().splitlines()[1])
        print(os.environ["{FORKSERVER_ENV}"])
        """)
    env = {k: v for k, v in os.environ.items() if k != FORKSERVER_ENV}
    result = subprocess.run([sys.executable, "-c", worker], cwd=ROOT, env=env, capture_output=True, text=True,
                            timeout=300)
    assert result.returncode == 0, result.stderr[-2000:]
    *boards, socket_path = result.stdout.splitlines()
    assert len(boards) == 2 and all(line.endswith("(forked by the warm server)") for line in boards), boards
    assert not any(socket_path in (p.info["cmdline"] or []) for p in psutil.process_iter(["cmdline"]))
    assert not os.path.exists(os.path.dirname(socket_path))
