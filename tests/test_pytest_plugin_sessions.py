"""The pytest plugin in pytest sessions that fly nothing: what it collects and when, how items are named and
selected, a sweep's samples, options pytest refuses, and every malformed scenario of the corpus reported as an
error naming its file and field. Each session is a `python -m pytest` in a directory outside the project, the
plugin loaded through its entry point as in a user's environment."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from tests.support.pytest_sessions import junit_cases, run_pytest, short_hover

pytestmark = pytest.mark.slow  # each session starts an interpreter and pytest (~1-3 s)

ROOT = Path(__file__).resolve().parent.parent
BAD_SCENARIOS = [ROOT / "tests" / "data" / "bad_scenarios" / f"{name}.yaml" for name in (
    "duration_zero", "board_config_typo", "unknown_keys_30", "top_level_list", "comment_only", "billion_laughs",
    "duplicate_duration", "expr_import", "python_object_tag", "unclosed_bracket", "seed_negative")] + [
    ROOT / "tests" / "data" / "bad_sweeps" / f"{name}.yaml" for name in (
        "cross_unknown_controller", "scenario_invalid", "uniform_every_draw_invalid", "dimension_typo")]
UNRELATED_TEST = "def test_unrelated():\n    assert 1 + 1 == 2\n"
SWEEP = """\
name: mc
scenario: hover.yaml
design: random
samples: 10
seed: 3
vary:
  seed: {integers: [1, 1000]}
cross:
  board.controller: [smarc, smpid]
"""


def collected(result) -> list[str]:
    return [line for line in result.stdout.splitlines() if "::" in line]


@pytest.fixture
def project(tmp_path: Path) -> Path:
    """A user's directory: an unrelated test, a scenario, a sweep of 10 samples x 2 controllers, a CI file."""
    (tmp_path / "test_unrelated.py").write_text(UNRELATED_TEST)
    short_hover(tmp_path, "hover")
    (tmp_path / "mc.yaml").write_text(SWEEP)
    (tmp_path / "ci.yml").write_text("name: CI\non: push\njobs: {test: {runs-on: ubuntu-latest}}\n")
    return tmp_path


def test_the_plugin_collects_nothing_unless_asked_and_hil_in_the_ini_file_asks(project):
    plain = run_pytest(project, "--collect-only", "-q")
    assert collected(plain) == ["test_unrelated.py::test_unrelated"], plain.stdout + plain.stderr
    (project / "pyproject.toml").write_text("[tool.pytest.ini_options]\nhil = true\n")
    asked = run_pytest(project, "--collect-only", "-q")
    assert sorted(collected(asked)) == ["hover.yaml::hover", *(f"mc.yaml::s{i:05d}" for i in range(20)),
                                        "test_unrelated.py::test_unrelated"], asked.stdout + asked.stderr


def test_the_projects_own_suite_is_collected_as_without_the_plugin():
    """tests/data holds the bad-scenario and bad-sweep corpora: none of their files becomes a test unless asked."""
    result = run_pytest(ROOT, "--collect-only", "-q", "tests/data", "tests/test_import_rules.py")
    assert collected(result) and all(item.startswith("tests/test_import_rules.py::") for item in collected(result))


def test_a_sweep_gives_one_item_per_sample_and_k_selects_the_crossed_controller(project):
    result = run_pytest(project, "--hil", "--collect-only", "-q", "mc.yaml", "--hil-limit", "4", "-k", "smpid")
    assert collected(result) == ["mc.yaml::s00001", "mc.yaml::s00003"]  # cross is innermost: smarc, smpid, ...
    assert "2/4 tests collected (2 deselected)" in result.stdout, result.stdout + result.stderr


def fake_px4_build(directory: Path) -> Path:
    """What `px4:DIR` checks before any run: an executable bin/px4 and etc/init.d-posix/rcS."""
    (directory / "bin").mkdir(parents=True)
    (directory / "etc" / "init.d-posix").mkdir(parents=True)
    (directory / "bin" / "px4").write_text("#!/bin/sh\n")
    os.chmod(directory / "bin" / "px4", 0o755)
    (directory / "etc" / "init.d-posix" / "rcS").write_text("")
    return directory


def test_items_are_parametrised_by_board_and_controller(project):
    px4 = fake_px4_build(project / "px4_sitl_default")
    args = ("--hil", "--collect-only", "-q", "hover.yaml", "--hil-board", "emulator", "--hil-board", f"px4:{px4}",
            "--hil-controller", "smarc,smpid")
    result = run_pytest(project, *args)
    assert collected(result) == ["hover.yaml::hover[emulator-smarc]", "hover.yaml::hover[emulator-smpid]",
                                 "hover.yaml::hover[px4-smarc]", "hover.yaml::hover[px4-smpid]"], result.stderr


@pytest.mark.parametrize(("option", "says"), [
    (("--hil-board", "nope"), "--hil-board nope: unknown board kind 'nope' (expected emulator, px4:..., "),
    (("--hil-board", "px4:/no/such/dir"), "/no/such/dir: no such directory"),
    (("--hil-board", "port:tcp:nohost"), "--hil-board tcp:nohost: "),
    (("--hil-controller", "smarc,pid"), "--hil-controller smarc,pid: unknown controller(s) pid; expected smarc"),
    (("--hil-limit", "0"), "--hil-limit 0: expected a number of samples, at least 1"),
])
def test_a_wrong_option_stops_the_session_with_one_line(tmp_path, capsys, option, says):
    """In this process (pytest.main): the options are checked when the session is configured, before collection."""
    assert pytest.main(["--hil", "--collect-only", "-q", "-p", "no:cacheprovider", str(tmp_path), *option]) == \
        pytest.ExitCode.USAGE_ERROR
    err = capsys.readouterr().err
    assert says in err and "Traceback" not in err, err


def test_malformed_scenarios_and_sweeps_are_errors_naming_their_file_and_field(tmp_path):
    """Files of the bad-scenario and bad-sweep corpora (each file's first line says what `hil check` or `hil sweep`
    must say), among them the ways to be wrong that a directory walk might take for something else: as test items,
    each is one error (not a failure) whose text names the file and holds that line, with no traceback and nothing
    flown."""
    result = run_pytest(tmp_path, "--hil", f"--junitxml={tmp_path / 'r.xml'}", *map(str, BAD_SCENARIOS))
    cases = junit_cases(tmp_path / "r.xml")
    assert len(cases) == len(BAD_SCENARIOS), result.stdout[-2000:]
    for path in BAD_SCENARIOS:
        case = next(case for key, case in cases.items() if key.endswith(f"{path.stem}.yaml::{path.stem}"))
        says = path.read_text().partition("\n")[0].removeprefix("# expect: ")
        assert case.outcome == "error", (path.name, case)
        assert str(path) in case.text and says in case.text, (path.name, case.text)
        assert "Traceback" not in case.text
    assert not (tmp_path / "runs").exists()  # no scenario reached a board
