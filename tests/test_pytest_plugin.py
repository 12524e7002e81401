"""The pytest plugin's parts without a flight or a pytest session: which YAML files it takes, where a test's run
directories go, the metrics by attribute, the texts a failure and an error show, the JUnit properties, scenario
fields replaced by their path; and that loading the plugin imports nothing of the bench."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from hil.scenario.loader import load_scenario
from hil.testing.collect import file_kind
from hil.testing.flight import with_changes
from hil.testing.results import Event, HilRun, HilRunError, Metrics, error_text, failure_text, junit_properties
from hil.testing.settings import run_subdir

ROOT = Path(__file__).resolve().parent.parent


def write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


@pytest.mark.parametrize(("text", "walked", "named"), [
    ("name: h\nduration_s: 3\nreference: {type: hover}\n", "scenario", "scenario"),
    ("name: only_a_name\n", "scenario", "scenario"),  # every field but the name has a default: it flies
    ("name: h\ndurration_s: 3\n", "scenario", "scenario"),  # a typo is still a scenario, refused when it loads
    ("name: mc\nscenario: h.yaml\nvary: {seed: {integers: [1, 9]}}\n", "sweep", "sweep"),
    ("name: CI\non: push\njobs: {test: {runs-on: ubuntu-latest}}\n", None, "scenario"),  # a GitHub workflow
    ("stages: [test]\nimage: python:3.11\n", None, "scenario"),  # a GitLab pipeline
    ("- name: h\n- duration_s: 3\n", None, "scenario"),
    ("# nothing but a comment\n", None, "scenario"),
    ("name: h\nduration_s: [unclosed\n", "scenario", "scenario"),  # broken YAML does not drop out unseen
    ("name: h\nname: i\n", "scenario", "scenario"),  # a duplicate key: the loader refuses it
])
def test_which_yaml_files_are_scenarios_or_sweeps(tmp_path, text, walked, named):
    path = write(tmp_path / "f.yaml", text)
    assert file_kind(path, named=False) == walked
    assert file_kind(path, named=True) == named


def test_an_alias_bomb_is_classified_within_the_loaders_bounds():
    """The corpus's billion laughs: refused by the loader's event-stream bound, so taken as a broken scenario
    (and reported as one), never built."""
    assert file_kind(ROOT / "tests" / "data" / "bad_scenarios" / "billion_laughs.yaml", named=False) == "scenario"


def test_a_file_larger_than_a_scenario_is_not_taken_unless_named(tmp_path):
    path = write(tmp_path / "big.yaml", "name: big\ndescription: " + "x" * 1_100_000 + "\n")
    assert file_kind(path, named=False) is None
    assert file_kind(path, named=True) == "scenario"


@pytest.mark.parametrize(("nodeid", "expected"), [
    ("scenarios/hover.yaml::hover", "scenarios/hover.yaml/hover"),
    ("scenarios/hover.yaml::hover[emulator-smpid]", "scenarios/hover.yaml/hover-emulator-smpid"),
    ("sweeps/mc.yaml::s00003[px4]", "sweeps/mc.yaml/s00003-px4"),
    ("tests/test_user.py::TestX::test_y[a b/c]", "tests/test_user.py/TestX/test_y-a_b/c"),
    ("../up.yaml::x", "up.yaml/x"),
])
def test_each_test_has_a_run_directory_of_its_own_named_after_its_id(nodeid, expected):
    assert run_subdir(nodeid) == Path(expected)


def test_metrics_read_by_attribute_as_by_key():
    metrics = Metrics({"position_error_m": {"z": {"max_abs": 0.25}}, "timing": {"realtime_factor": 3.5}})
    assert metrics.position_error_m.z.max_abs == 0.25
    assert metrics["timing"]["realtime_factor"] == 3.5
    assert dict(metrics.timing) == {"realtime_factor": 3.5}
    with pytest.raises(AttributeError, match="no metric 'attitude_error_deg' in this run; it has position_error_m, "
                                             "timing"):
        _ = metrics.attitude_error_deg


def a_run(tmp_path: Path, exit_code: int, **fields) -> HilRun:
    scenario = load_scenario(write(tmp_path / "s.yaml", "name: hold\nseed: 7\n"))
    defaults = {"board": "emulator", "autopilot": "emulator, controller smarc", "reason": "completed",
                "failures": [], "run_dir": tmp_path / "run", "summary": "", "metrics": Metrics({}), "events": [],
                "report": None}
    return HilRun(scenario, exit_code=exit_code, **{**defaults, **fields})


def test_a_failure_shows_each_expectation_missed_and_where_the_run_is(tmp_path):
    run = a_run(tmp_path, 1, failures=["max |e_z| = 0.520 m after 5 s, expected ≤ 0.4 m"],
                report=tmp_path / "run" / "report.html")
    assert failure_text(run).splitlines() == [
        "hold on emulator (emulator, controller smarc): FAIL", "  the run: completed",
        "  expectation not met: max |e_z| = 0.520 m after 5 s, expected ≤ 0.4 m",
        f"run directory: {tmp_path / 'run'}", f"report: {tmp_path / 'run' / 'report.html'}"]


def test_a_board_error_quotes_the_boards_last_texts_once_each_and_its_log(tmp_path):
    (tmp_path / "run").mkdir()
    (tmp_path / "run" / "emulator.log").write_text("")
    events = [Event(0.1, "phase preflight -> offboard"), *[Event(0.2 + i, "board: Arming denied") for i in range(3)],
              Event(4.0, "board: Failsafe: no HIL_SENSOR")]
    text = error_text(a_run(tmp_path, 3, reason="board did not arm within 60 s", events=events))
    assert text.splitlines() == [
        "hold on emulator: exit 3 (BOARD): board did not arm within 60 s",
        "the board's last texts: Arming denied (3 times) | Failsafe: no HIL_SENSOR",
        f"board log: {tmp_path / 'run' / 'emulator.log'}", f"run directory: {tmp_path / 'run'}"]


def test_junit_properties_are_strings_named_as_in_metrics_json(tmp_path):
    metrics = Metrics({"timing": {"realtime_factor": 4.25},
                       "position_error_m": {a: {"max_abs": 0.1 * (i + 1)} for i, a in enumerate("xyz")},
                       "attitude_error_deg": {a: {"max_abs": 1.5} for a in ("roll", "pitch", "yaw")}})
    properties = dict(junit_properties(a_run(tmp_path, 0, metrics=metrics)))
    assert properties == {
        "exit_code": "0", "reason": "completed", "board": "emulator", "autopilot": "emulator, controller smarc",
        "seed": "7", "run_dir": str(tmp_path / "run"), "timing.realtime_factor": "4.250",
        "position_error_m.x.max_abs": "0.1", "position_error_m.y.max_abs": "0.2", "position_error_m.z.max_abs": "0.3",
        "attitude_error_deg.roll.max_abs": "1.5", "attitude_error_deg.pitch.max_abs": "1.5",
        "attitude_error_deg.yaw.max_abs": "1.5"}


def test_a_run_without_a_mission_has_no_error_properties(tmp_path):
    names = [name for name, _ in junit_properties(a_run(tmp_path, 3, reason="board/link failure"))]
    assert names == ["exit_code", "reason", "board", "autopilot", "seed", "run_dir"]


def test_fields_are_replaced_by_their_path_and_validated_again(tmp_path):
    gust = "{start_s: 1, duration_s: 1, peak_ned: [1, 0, 0]}"
    scenario = load_scenario(write(tmp_path / "s.yaml", f"name: g\nwind: {{gusts: [{gust}]}}\n"))
    changed = with_changes(scenario, {"seed": 5, "board.controller": "smpid", "wind.gusts[0].peak_ned": [0, 3, 0]},
                           "test")
    assert (changed.seed, changed.board.controller, changed.wind.gusts[0].peak_ned) == (5, "smpid", (0, 3, 0))
    assert with_changes(scenario, {}, "test") is scenario
    with pytest.raises(HilRunError, match=r"^g: --hil-seed: seed: found -1, expected: input should be greater than "
                                          r"or equal to 0$"):
        with_changes(scenario, {"seed": -1}, "--hil-seed")
    with pytest.raises(HilRunError, match=r"^g: hil_run: wind.gusts\[3\].peak_ned: no item \[3\]"):
        with_changes(scenario, {"wind.gusts[3].peak_ned": [0, 0, 0]}, "hil_run")


def test_loading_the_plugin_imports_nothing_of_the_bench():
    """pytest imports the plugin in every session of an environment with hil-bench installed: it must not bring
    in numpy, fmpy, pydantic, Zenoh or the bench's modules, the exit codes' enum aside (the sessions that do not
    ask pay nothing)."""
    code = ("import sys, pytest; before = set(sys.modules); import hil.testing.plugin; "
            "print(' '.join(sorted(set(sys.modules) - before)))")
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    ours = {m for m in loaded if m.split(".")[0] in ("hil", "plant_fmu", "firmware_interface")}
    assert ours == {"hil", "hil.exit_codes", "hil.testing", "hil.testing.collect", "hil.testing.fixtures",
                    "hil.testing.plugin", "hil.testing.results", "hil.testing.settings"}
    assert not {m for m in loaded if m.split(".")[0] in ("numpy", "fmpy", "pydantic", "zenoh", "matplotlib")}
