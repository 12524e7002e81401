"""The commands other than `hil check` and `hil sweep` on bad input: each exits 2 in one line naming the option or
the file, no traceback, nothing started and nothing moved. Run through the CLI's `main` in this process (an
exception escaping it fails the test as a traceback would); none of these cases gets as far as a board.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import subprocess
from pathlib import Path

import pytest
from mcap.writer import Writer

from hil.app.cli import main

ROOT = Path(__file__).resolve().parent.parent
SHORT_HOVER = ROOT / "tests" / "data" / "short_hover.yaml"


def hil(*args: str) -> tuple[int, list[str], str]:
    """`hil ARGS` in this process: exit code, stderr lines, stdout."""
    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        try:
            code = main(list(args))
        except SystemExit as exc:
            code = int(exc.code or 0)
    return code, err.getvalue().splitlines(), out.getvalue()


def assert_one_line(args: list[str], says: str) -> None:
    code, lines, _ = hil(*args)
    assert code == 2 and len(lines) == 1, lines
    assert says in lines[0], f"expected {says!r} in {lines[0]!r}"


def _with_mission_state(run_dir: Path) -> None:
    """A run directory whose recording holds one mission-phase state sample: enough for the report to read on."""
    run_dir.mkdir()
    with open(run_dir / "recording.mcap", "wb") as file:
        writer = Writer(file)
        writer.start()
        schema = writer.register_schema("state", "jsonschema", b"{}")
        channel = writer.register_channel("hil/state", "json", schema)
        writer.add_message(channel, 1, json.dumps({"t_us": 1, "mission_t": 0.0, "phase": "mission"}).encode(), 1)
        writer.finish()


@pytest.mark.slow  # the first import of the report modules (matplotlib): ~1 s
def test_report_of_a_run_whose_metrics_json_is_cut_short(tmp_path):
    run_dir = tmp_path / "run"
    _with_mission_state(run_dir)
    (run_dir / "metrics.json").write_text('{"exit_code": 0, "reason": "comp')
    assert_one_line(["report", str(run_dir)], f"{run_dir / 'metrics.json'}: not valid JSON, cut short?")
    (run_dir / "metrics.json").write_text("[1, 2]")
    assert_one_line(["report", str(run_dir)], "metrics.json: expected a JSON object, found list")


@pytest.mark.parametrize("content, says", [(b"", "empty file, nothing to recover"),
                                           (bytes(range(256)) * 64, "not an MCAP recording"),
                                           (b"\x89MCAP0\r\n" + b"\x00" * 100, "not one whole message in it")])
def test_recover_of_a_file_with_nothing_to_recover_leaves_it_where_it_was(tmp_path, content, says):
    (tmp_path / "recording.mcap").write_bytes(content)
    assert_one_line(["recover", str(tmp_path)], says)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["recording.mcap"]
    assert (tmp_path / "recording.mcap").read_bytes() == content


@pytest.mark.parametrize("key", ["", "hil//state", "hil/**/**", "hil/*x*", "hil/state?"])
def test_echo_of_an_invalid_key_expression(key):
    assert_one_line(["echo", key], f"hil echo: key expression {key!r}: ")


@pytest.mark.parametrize("command", [["echo", "hil/**"], ["watch", "--latest"], ["foxglove"]])
def test_a_missing_zenoh_configuration_file(command, tmp_path):
    assert_one_line([*command, "--zenoh-config", str(tmp_path / "none.json5")], "--zenoh-config")


@pytest.mark.parametrize("options, says", [
    (["--seeds", "0"], "--seeds 0: expected 1 to 1000"),
    (["--seeds", "-2"], "--seeds -2: expected 1 to 1000"),
    (["--jobs", "0"], "--jobs 0: expected 1 to"),
    (["--jobs", "-1"], "--jobs -1: expected 1 to"),
    (["--controllers", ","], "--controllers ,: none"),
    (["--controllers", "smarc,pid"], "--controllers smarc,pid: unknown pid"),
])
def test_compare_options(options, says, tmp_path):
    assert_one_line(["compare", str(SHORT_HOVER), *options, "--out", str(tmp_path / "c")], f"hil compare: {says}")
    assert not (tmp_path / "c").exists()


RUN_OPTIONS = {
    "baud_zero": (["--baud", "0"], "--baud 0: not a serial baud rate"),
    "baud_odd": (["--baud", "12345"], "--baud 12345: not a serial baud rate"),
    "gcs_unresolvable": (["--gcs", "udpout:notahost:14550"], "--gcs udpout:notahost:14550: cannot resolve host"),
    "mavlink_unresolvable": (["--mavlink", "udpout:nohost.invalid:1"], "--mavlink udpout:nohost.invalid:1: cannot"),
    "gcs_port": (["--gcs", "udpout:127.0.0.1:70000"], "--gcs udpout:127.0.0.1:70000: bad port"),
    "connect_timeout_zero": (["--connect-timeout", "0"], "--connect-timeout 0: expected seconds above 0"),
    "connect_timeout_negative": (["--connect-timeout", "-3"], "--connect-timeout -3: expected seconds above 0"),
    "connect_timeout_nan": (["--connect-timeout", "nan"], "--connect-timeout nan: expected seconds above 0"),
}


@pytest.mark.parametrize("name", RUN_OPTIONS)
def test_run_options_refused_before_any_board_starts(name, tmp_path):
    options, says = RUN_OPTIONS[name]
    runs = tmp_path / "runs"
    assert_one_line(["run", str(SHORT_HOVER), "--no-telemetry", "--runs", str(runs), *options], f"hil run: {says}")
    assert not runs.exists()


def test_runs_below_a_file(tmp_path):
    (tmp_path / "file").write_text("x")
    assert_one_line(["run", str(SHORT_HOVER), "--runs", str(tmp_path / "file" / "runs")], "file is a file")


@pytest.fixture
def read_only_folder(tmp_path):
    folder = tmp_path / "ro"
    folder.mkdir()
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", "ro,size=1m", "tmpfs", str(folder)], capture_output=True,
                             text=True)
    if mounted.returncode != 0:
        pytest.skip(f"a read-only mount needs mount(8) as root: {mounted.stderr.strip() or 'not allowed'}")
    yield folder
    subprocess.run(["umount", str(folder)], check=True)


def test_runs_on_a_read_only_filesystem(read_only_folder):
    runs = read_only_folder / "runs"
    assert_one_line(["run", str(SHORT_HOVER), "--no-telemetry", "--runs", str(runs)],
                    f"hil run: --runs {runs}: cannot be written ({read_only_folder}: Read-only file system)")
    assert_one_line(["sweep", str(ROOT / "sweeps" / "paper_gains.yaml"), "--out", str(read_only_folder / "out")],
                    "Read-only file system")
    assert os.listdir(read_only_folder) == []


@pytest.mark.parametrize("args, says", [
    (["--speed-factor", "0"], "--speed-factor 0: expected a factor above 0 and at most 100"),
    (["--speed-factor", "4", "--realtime"], "--speed-factor 4: --realtime paces at 1; give one of them"),
    (["--speed-factor", "4", "--port", "/dev/ttyACM0"], "--speed-factor 4: /dev/ttyACM0 runs on its own clock"),
])
def test_a_speed_factor_only_a_lockstep_board_can_run_at(args, says, tmp_path):
    assert_one_line(["run", str(SHORT_HOVER), "--runs", str(tmp_path), "--no-telemetry", *args], says)
    assert list(tmp_path.iterdir()) == []  # nothing started
