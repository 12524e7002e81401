"""The pytest plugin flying: scenarios written for these tests (a 2 m hover of a few seconds), in pytest sessions
outside the project as a user's CI runs them. The verdicts in JUnit (pass, a missed expectation as a failure, a
malformed scenario and a dead board as errors), pytest-xdist flying items side by side on their own ptys and Zenoh
keys, the fixtures in a user's own test, and real PX4."""

from __future__ import annotations

import json
import re
import signal
import subprocess
import sys
import threading
from itertools import combinations
from pathlib import Path

import pytest
from mcap.reader import make_reader

from hil.outputs.telemetry import subscribe
from tests.support.cli_runs import wait_flying
from tests.support.ports import free_port
from tests.support.pytest_sessions import junit_cases, run_pytest, short_hover

pytestmark = pytest.mark.e2e

HOLDS = "1 m holds: the px4_sitl GPS's slow error (sigma 0.3 m) with margin; the emulator's hover shows ~0.1 m"
MISSES = "1 mm cannot hold: the px4_sitl GPS alone wanders by decimetres (sigma 0.3 m, tau 60 s)"


def run_dirs(root: Path) -> list[Path]:
    return sorted(p.parent for p in root.rglob("meta.json"))


def test_each_scenario_is_a_testcase_with_the_runs_verdict(tmp_path):
    """Two boards: the emulator flies; a `port:` nobody listens on is a board failure, exit 3, an error."""
    scenarios = tmp_path / "scenarios"
    scenarios.mkdir()
    short_hover(scenarios, "holds", why=HOLDS)
    short_hover(scenarios, "misses", bound_m=0.001, why=MISSES)
    (scenarios / "broken.yaml").write_text("name: broken\nduration_s: -3\n")
    dead = f"port:tcp:127.0.0.1:{free_port()}"
    result = run_pytest(tmp_path, "--hil", "scenarios", "--hil-board", "emulator", "--hil-board", dead,
                        "--hil-runs", "out", "--hil-report", "failed", "--junitxml", "r.xml")
    cases = junit_cases(tmp_path / "r.xml")
    outcomes = {key: case.outcome for key, case in cases.items()}
    assert outcomes == {
        "scenarios.holds.yaml::holds[emulator]": "passed", "scenarios.misses.yaml::misses[emulator]": "failure",
        "scenarios.broken.yaml::broken[emulator]": "error", "scenarios.broken.yaml::broken[port]": "error",
        "scenarios.holds.yaml::holds[port]": "error", "scenarios.misses.yaml::misses[port]": "error"}, result.stdout

    holds = cases["scenarios.holds.yaml::holds[emulator]"].properties
    metrics = json.loads((Path(holds["run_dir"]) / "metrics.json").read_text())
    assert Path(holds["run_dir"]).is_relative_to(tmp_path / "out" / "scenarios" / "holds.yaml" / "holds-emulator")
    assert (holds["exit_code"], metrics["exit_code"]) == ("0", 0)
    # the session's emulators come from its own warm fork server
    assert "(forked by the warm server)" in (Path(holds["run_dir"]) / "summary.txt").read_text()
    assert float(holds["position_error_m.z.max_abs"]) == pytest.approx(metrics["position_error_m"]["z"]["max_abs"],
                                                                       rel=1e-5)
    assert float(holds["timing.realtime_factor"]) > 0 and "report" not in holds  # --hil-report failed

    misses = cases["scenarios.misses.yaml::misses[emulator]"]
    missed = json.loads((Path(misses.properties["run_dir"]) / "metrics.json").read_text())["expectations_failed"]
    assert len(missed) == 3 and all(f"expectation not met: {line}" in misses.text for line in missed)
    assert "max |e_z| = " in misses.text and "expected ≤ 0.001 m" in misses.text
    assert Path(misses.properties["report"]).is_file() and f"report: {misses.properties['report']}" in misses.text

    broken = cases["scenarios.broken.yaml::broken[emulator]"]
    assert f"{scenarios / 'broken.yaml'}:2: duration_s: found -3" in broken.text
    dead_board = cases["scenarios.holds.yaml::holds[port]"]
    assert "exit 3 (BOARD): board/link failure: cannot connect to 127.0.0.1" in dead_board.text
    assert dead_board.properties["exit_code"] == "3"


def test_xdist_flies_items_side_by_side_each_on_its_own_pty_and_zenoh_key(tmp_path):
    """`-n 2` over 2 scenarios x 2 controllers, each run publishing on Zenoh: the runs that overlap in time hold
    different ptys, each run's samples arrive under a key of its own (its run id) in order, and no run relays to
    the ground-station port."""
    for name in ("first", "second"):
        short_hover(tmp_path, name, why=HOLDS)
    state: dict[str, list[int]] = {}
    summaries: dict[str, dict] = {}
    lock = threading.Lock()

    def on_sample(key: str, sample: dict) -> None:
        run_id, channel = key.split("/", 2)[1:]
        with lock:
            if channel == "state":
                state.setdefault(run_id, []).append(sample["t_us"])
            elif channel == "summary":
                summaries[run_id] = sample

    subscription = subscribe("hil/*/state", on_sample)
    summary_subscription = subscribe("hil/*/summary", on_sample)
    try:
        result = run_pytest(tmp_path, "--hil", "first.yaml", "second.yaml", "-n", "2", "--hil-controller",
                            "smarc,smpid", "--hil-telemetry", "--hil-report", "none", "--hil-runs", "out")
    finally:
        subscription.close()
        summary_subscription.close()
    assert result.returncode == 0 and "4 passed" in result.stdout, result.stdout + result.stderr
    runs = run_dirs(tmp_path / "out")
    assert len(runs) == 4
    spans = {}
    for run in runs:
        start_s = json.loads((run / "meta.json").read_text())["start_unix_ns"] * 1e-9
        pty = re.search(r"emulator on (/dev/pts/\d+)", (run / "summary.txt").read_text()).group(1)
        spans[run.name] = (start_s, (run / "metrics.json").stat().st_mtime, pty)
        assert "gcs" not in json.loads((run / "metrics.json").read_text())  # no relay to udp 14550
    overlapping = [(a, b) for a, b in combinations(spans.values(), 2) if a[0] < b[1] and b[0] < a[1]]
    assert overlapping, spans  # two workers flew at once
    assert all(a[2] != b[2] for a, b in overlapping), overlapping
    ours = {run.name for run in runs}
    assert ours <= set(summaries), (ours, set(summaries))
    for run_id in ours:
        assert summaries[run_id]["metrics"]["exit_code"] == 0
        assert state[run_id] == sorted(set(state[run_id])), run_id  # one run's samples, none from another


@pytest.mark.usefixtures("fresh_emulators")  # found by its command line after the session
def test_a_sigterm_mid_flight_lands_the_run_and_ends_the_session(tmp_path):
    """A CI job cancelled (SIGTERM to pytest): the run in flight ends as `hil run` ends on it, its files closed (the
    recording reads to its end), the emulator stopped, and pytest stops as interrupted."""
    short_hover(tmp_path, "long", duration_s=120, why=HOLDS)
    session = subprocess.Popen([sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "--hil", "long.yaml",
                                "--hil-runs", "out", "--hil-report", "none"], cwd=tmp_path, stdout=subprocess.PIPE,
                               stderr=subprocess.STDOUT, text=True)
    try:
        wait_flying(tmp_path / "out" / "long.yaml" / "long")
        session.send_signal(signal.SIGTERM)
        output, _ = session.communicate(timeout=60)
    finally:
        session.kill()
    assert session.returncode == pytest.ExitCode.INTERRUPTED, output
    assert "KeyboardInterrupt: interrupted (SIGTERM)" in output
    (run,) = run_dirs(tmp_path / "out")
    metrics = json.loads((run / "metrics.json").read_text())
    assert (metrics["exit_code"], metrics["reason"]) == (130, "interrupted (SIGTERM)")
    with open(run / "recording.mcap", "rb") as file:
        states = sum(1 for _, channel, _ in make_reader(file).iter_messages() if channel.topic == "hil/state")
    assert states > 250  # over a second of flight at 250 Hz, read through the file's own index
    processes = subprocess.run(["ps", "-eo", "args"], capture_output=True, text=True).stdout.splitlines()
    assert not [line for line in processes if "firmware_interface.emulator" in line and str(run) in line]


USER_TEST = '''\
from pathlib import Path

import numpy as np

HERE = Path(__file__).parent


def test_hover_on_the_emulator(hil_run, hil_emulator):
    run = hil_run(HERE / "hover.yaml", board=hil_emulator, overrides={"duration_s": 3})
    assert run.passed and run.scenario.duration_s == 3
    assert run.metrics.position_error_m.z.max_abs < 0.3
    mission = run.mission  # the recording, read back
    settled = mission.t >= run.scenario.expect.settle_s
    assert np.max(np.abs(mission.error[settled, 2])) == run.metrics.position_error_m.z.max_abs
    texts = [e.text for e in run.events]
    assert "board: Armed (smarc)" in texts and any(t.startswith("phase takeoff -> mission") for t in texts)


def test_another_controller_and_seed(hil_run):
    run = hil_run(HERE / "hover.yaml", controller="smpid", seed=4)
    assert run.autopilot == "emulator, controller smpid" and run.scenario.seed == 4
    assert "board: Armed (smpid)" in [e.text for e in run.events]
    assert run.metrics.timing.realtime_factor > 0
'''


def test_the_fixtures_fly_a_scenario_in_a_users_own_test(tmp_path):
    """A user's test asserts on the metrics by attribute, on the mission read back from the recording (its largest
    settled height error is the metric: the run's live judge and the recording agree), and on the run's events."""
    short_hover(tmp_path, "hover", why=HOLDS)
    (tmp_path / "test_user.py").write_text(USER_TEST)
    result = run_pytest(tmp_path, "test_user.py", "--hil-runs", "out", "--hil-report", "none")
    assert result.returncode == 0 and "2 passed" in result.stdout, result.stdout + result.stderr
    assert [p.parent.name for p in run_dirs(tmp_path / "out")] == ["test_another_controller_and_seed",
                                                                   "test_hover_on_the_emulator"]


@pytest.mark.px4
def test_a_scenario_flies_real_px4_as_an_item_and_through_hil_px4(tmp_path):
    """`pytest --hil hover.yaml --hil-board px4:BUILD`, and a user's test on `hil_px4`: each flight its own PX4."""
    from tests.support.px4_builds import px4_build, px4_root

    build = px4_build(px4_root(), "sitl", tmp_path / "px4")
    short_hover(tmp_path, "hover", why="1 m holds for PX4 too: its own EKF on the same GPS")
    (tmp_path / "test_px4.py").write_text(
        "def test_hover(hil_run, hil_px4):\n"
        "    run = hil_run('hover.yaml', board=hil_px4)\n"
        "    assert run.passed and run.autopilot.startswith('PX4')\n"
        "    assert any(e.text.startswith('board: ') for e in run.events)\n")
    result = run_pytest(tmp_path, "--hil", "hover.yaml", "test_px4.py", "--hil-board", f"px4:{build}",
                        "--hil-px4", str(build), "--hil-runs", "out", "--hil-report", "none", "--junitxml", "r.xml")
    assert result.returncode == 0 and "2 passed" in result.stdout, result.stdout + result.stderr
    item = junit_cases(tmp_path / "r.xml")["hover.yaml::hover"].properties
    assert item["autopilot"] == "PX4 (its own estimator and controllers)"
    assert all((run / "px4.log").is_file() for run in run_dirs(tmp_path / "out"))
