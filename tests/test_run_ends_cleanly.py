"""Whatever ends a run — a bench bug, a signal at any moment, Ctrl-C during shutdown, a taken port — it
ends with a summary, metrics, a recording the indexed MCAP reader opens, and nothing left behind."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest
from mcap.reader import make_reader

from hil.host.stop_signals import stopped_by_signals, uninterrupted
from hil.loop.frame import StepFrame
from hil.loop.sink import FrameSink
from hil.run.runner import RunOptions, run_scenario
from hil.scenario.loader import load_scenario
from tests.support.cli_runs import emulator_pids, frames_flowed, wait_flying
from tests.support.summary_text import summary_field

pytestmark = pytest.mark.e2e  # drives the bench's processes (hil, the emulator) end to end

ROOT = Path(__file__).resolve().parent.parent


def hover_file(tmp_path: Path, seconds: float) -> Path:
    path = tmp_path / "hold.yaml"
    path.write_text(f"name: hold\nduration_s: {seconds}\nseed: 2\nreference: {{type: hover, altitude_m: 3}}\n")
    return path


def plant_temp_dirs(tmp: Path) -> list[Path]:
    """The plant's unpacked FMU folders left in the run's own temporary directory."""
    return list(tmp.glob("quadrotor-*"))


@pytest.fixture
def own_tmp(tmp_path, monkeypatch) -> Path:
    """A temporary directory for this test alone (this process and the runs it starts), so that other
    runs on the machine do not show up in it."""
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(tmp))
    monkeypatch.setenv("TMPDIR", str(tmp))
    return tmp


def assert_run_closed(run_dir: Path, exit_code: int, flew: bool = True) -> str:
    """Summary and metrics written, the recording complete (indexed) with its metadata, and (once the
    flight had begun) its samples readable."""
    summary = (run_dir / "summary.txt").read_text()
    assert json.loads((run_dir / "metrics.json").read_text())["exit_code"] == exit_code
    with open(run_dir / "recording.mcap", "rb") as f:
        reader = make_reader(f)
        assert reader.get_summary() is not None
        assert (sum(1 for _ in reader.iter_messages(topics=["hil/state"])) > 0) or not flew
        assert {m.name for m in reader.iter_metadata()} >= {"scenario", "run", "metrics"}
    return summary


def test_an_error_nobody_expected_is_exit_4_with_its_traceback_in_bench_log(tmp_path, own_tmp):
    def broken_sink(frame: StepFrame) -> None:  # a user's sink with a bug, 2 s into the flight
        if frame.t_us > 2_000_000:
            raise ZeroDivisionError("a sink divided by zero")

    scenario = load_scenario(hover_file(tmp_path, 10.0))
    outcome = run_scenario(scenario, RunOptions(runs_root=tmp_path / "runs", telemetry=None, gcs=[]),
                           sinks=[FrameSink(broken_sink)])
    assert outcome.exit_code == 4
    summary = assert_run_closed(outcome.run_dir, 4)
    ended = summary_field(summary, "ended")
    assert "internal error" in ended and "ZeroDivisionError: a sink divided by zero" in ended
    assert "bench.log" in ended and "bench time 2.0" in ended
    log = (outcome.run_dir / "bench.log").read_text()
    assert log.startswith("Traceback") and "broken_sink" in log
    assert not plant_temp_dirs(own_tmp)


def hil_run(*args: str) -> subprocess.Popen[str]:
    return subprocess.Popen([sys.executable, "-m", "hil", "run", "--no-report", "--no-gcs", *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)


def test_a_zenoh_port_already_taken_is_bad_input_before_any_board(tmp_path):
    taken = socket.socket()
    taken.bind(("127.0.0.1", 0))
    taken.listen()
    runs = tmp_path / "runs"
    bench = hil_run(str(hover_file(tmp_path, 5.0)), "--runs", str(runs), "--zenoh-listen",
                    f"tcp/127.0.0.1:{taken.getsockname()[1]}")
    out, err = bench.communicate(timeout=60)
    taken.close()
    assert bench.returncode == 2, out + err
    assert "Traceback" not in err
    assert "ended: Zenoh: Can not create a new TCP listener" in out
    assert "run directory removed: the board never connected" in out  # no board was started
    assert not list(runs.iterdir())


def test_an_attempt_that_never_connects_leaves_no_run_directory_unless_asked(tmp_path):
    for keep, expected in ((False, 0), (True, 1)):
        runs = tmp_path / f"runs{keep}"
        bench = hil_run("scenarios/hover.yaml", "--runs", str(runs), "--port", "/dev/ttyACM97", "--no-telemetry",
                        *(["--keep-failed"] if keep else []))
        out, _ = bench.communicate(timeout=60)
        assert bench.returncode == 3 and "ended: board/link failure: no device /dev/ttyACM97" in out
        assert len(list(runs.iterdir())) == expected
        if keep:
            (run_dir,) = runs.iterdir()
            assert "no device /dev/ttyACM97" in (run_dir / "summary.txt").read_text()


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def _signal_run(tmp_path: Path, signals: list[tuple[float, int]],
                in_flight: bool = False) -> tuple[int, Path, list[int], bool]:
    """Start a run, send each (delay, signal), wait; exit code, run dir, the emulator's pid (a fresh process, the
    bench's child: `fresh_emulators`), and whether the run had stepped by the time its signals went. Delays count
    from the emulator's start, or with `in_flight` from the run's first second of stepping (the emulator's pid
    not looked for): a machine running three test files at a time took over 2 s to start stepping.
    (--keep-failed: a run stopped before the board spoke keeps its directory too.)"""
    runs = tmp_path / "runs"
    # a mission far longer than any signal's delay, however fast the machine flies it: the signal ends it
    bench = hil_run(str(hover_file(tmp_path, 600.0)), "--runs", str(runs), "--no-telemetry", "--keep-failed")
    children: list[int] = []
    if in_flight:
        wait_flying(runs, then_s=0.0)
    else:
        deadline = time.monotonic() + 60
        while not (children := emulator_pids(bench.pid)) and time.monotonic() < deadline:
            time.sleep(0.05)
    started = time.monotonic()
    stepped = False
    for delay, signum in signals:
        time.sleep(max(0.0, started + delay - time.monotonic()))
        stepped = stepped or frames_flowed(runs)
        bench.send_signal(signum)
    bench.communicate(timeout=60)
    (run_dir,) = runs.iterdir()
    return bench.returncode, run_dir, children, stepped


@pytest.mark.slow
# after the emulator's start: its imports and compiled code (~0-1 s), the wait for its heartbeat, then stepping
# (by 1.5 s on a quiet machine): preflight, take-off and the mission follow each other within a second or two
@pytest.mark.parametrize("delay_s", [0.2, 0.5, 0.8, 1.1, 1.4, 1.7, 2.0, 2.5, 3.0, 4.0])
@pytest.mark.usefixtures("fresh_emulators")
def test_sigterm_at_any_moment_closes_the_run(tmp_path, own_tmp, delay_s):
    code, run_dir, children, stepped = _signal_run(tmp_path, [(delay_s, signal.SIGTERM)])
    assert code == 130
    summary = assert_run_closed(run_dir, 130, flew=stepped)
    assert "interrupted (SIGTERM)" in summary
    time.sleep(0.5)
    assert not [pid for pid in children if _alive(pid)]  # the emulator went with the bench
    assert not plant_temp_dirs(own_tmp)


@pytest.mark.slow
@pytest.mark.parametrize("gap_s", [0.0, 0.02, 0.05, 0.08, 0.1, 0.12, 0.15, 0.2, 0.3, 0.5])
def test_a_second_ctrl_c_during_shutdown_waits_for_the_files(tmp_path, gap_s):
    code, run_dir, _, _ = _signal_run(tmp_path, [(0.5, signal.SIGINT), (0.5 + gap_s, signal.SIGINT)], in_flight=True)
    assert code == 130
    assert "interrupted" in assert_run_closed(run_dir, 130)


@pytest.mark.slow
def test_sighup_ends_the_run_as_ctrl_c_does(tmp_path):
    code, run_dir, _, _ = _signal_run(tmp_path, [(0.5, signal.SIGHUP)], in_flight=True)
    assert code == 130
    assert "interrupted (SIGHUP)" in assert_run_closed(run_dir, 130)


def test_an_expression_that_fails_mid_flight_ends_the_run_with_its_field_and_time(tmp_path):
    scenario = tmp_path / "sqrt.yaml"
    # negative under the root only for 3 s < t < 4 s: fine at the times `hil check` tries (0, 10, 20 s)
    scenario.write_text("name: sqrt\nduration_s: 20\nreference: {type: hover, altitude_m: 3}\nend: disarm\n"
                        "disturbance: {force_ned: [0, 'sqrt(t*t - 7*t + 12)', 0]}\n")
    assert subprocess.run([sys.executable, "-m", "hil", "check", str(scenario)], cwd=ROOT).returncode == 0
    runs = tmp_path / "runs"
    bench = hil_run(str(scenario), "--runs", str(runs), "--no-telemetry")
    out, err = bench.communicate(timeout=120)
    assert bench.returncode == 1, out + err
    assert "Traceback" not in err
    (run_dir,) = runs.iterdir()
    ended = summary_field(assert_run_closed(run_dir, 1), "ended")
    assert "disturbance.force_ned.1" in ended and "sqrt(t*t - 7*t + 12)" in ended
    t = float(ended.split("fails at t = ")[1].split(" s")[0])
    assert 3.0 < t < 3.01  # the first step past the root, on the mission clock


@pytest.mark.parametrize("option", [["--seed", "-1"], ["--telemetry-rate", "state=0"],
                                    ["--telemetry-rate", "stat=50"]])
def test_run_options_are_validated_as_the_file_is(tmp_path, option):
    runs = tmp_path / "runs"
    bench = hil_run(str(hover_file(tmp_path, 5.0)), "--runs", str(runs), *option)
    _out, err = bench.communicate(timeout=60)
    assert bench.returncode == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not runs.exists()  # refused before any run directory or board


def test_a_force_that_turns_nan_mid_flight_ends_the_run_naming_it(tmp_path):
    scenario = tmp_path / "nan.yaml"
    # inf - inf = nan for 3 s < t < 4 s only; 0 at the times `hil check` tries
    grow = "max(0, (t - 3)*(4 - t))*1e300*1e300"
    scenario.write_text("name: nan\nduration_s: 20\nreference: {type: hover, altitude_m: 3}\nend: disarm\n"
                        f"disturbance: {{force_ned: ['{grow} - {grow}', 0, 0]}}\n")
    runs = tmp_path / "runs"
    bench = hil_run(str(scenario), "--runs", str(runs), "--no-telemetry")
    out, err = bench.communicate(timeout=120)
    assert bench.returncode == 1 and "Traceback" not in err, out + err
    (run_dir,) = runs.iterdir()
    ended = summary_field(assert_run_closed(run_dir, 1), "ended")
    assert "disturbance.force_ned.0" in ended and "not a finite number" in ended


def test_a_stop_signal_inside_a_recording_write_is_held_until_the_write_ends():
    """CI once lost a recording to a Ctrl-C that landed inside the MCAP writer: half a record in a chunk."""
    steps: list[str] = []
    with stopped_by_signals(), pytest.raises(KeyboardInterrupt, match="Ctrl-C"):
        with uninterrupted():
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.05)  # the handler has run by now (it runs between bytecodes of this thread)
            steps.append("write finished")
        steps.append("after the write")
    assert steps == ["write finished"]
    with stopped_by_signals(), pytest.raises(KeyboardInterrupt):  # outside a write it raises where it lands
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.05)
        steps.append("not reached")
    assert steps == ["write finished"]
