"""`hil sweep` on malformed sweep files and options: each exits 2 (3 for a cluster that does not answer) within
30 s, in 1-20 lines that name the file and the field or the option, never a traceback; nothing is started and no
results directory is made for it.

The corpus is tests/data/bad_sweeps/*.yaml, each file's first line `# expect: <text the output must hold>`. The
cases run in this process through the CLI's `main` (an exception escaping it fails the test, as a traceback
would); the cluster cases and one file run as `hil` processes, to see the exit code and the processes left.
"""

from __future__ import annotations

import contextlib
import io
import os
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from firmware_interface.forkserver import FORKSERVER_ENV
from hil.app.cli import main
from hil.sweep.options import max_jobs
from tests.support.ports import free_port

ROOT = Path(__file__).resolve().parent.parent
CORPUS = sorted((ROOT / "tests" / "data" / "bad_sweeps").glob("*.yaml"))
SHORT_HOVER = ROOT / "tests" / "data" / "short_hover.yaml"
LIMIT_S = 30.0


def expected(path: Path) -> str:
    first = path.read_bytes().partition(b"\n")[0].decode()
    assert first.startswith("# expect: "), f"{path.name}: the first line must be '# expect: ...'"
    return first.removeprefix("# expect: ")


def children() -> list[str]:
    """This process's children (a LocalCluster's workers, an emulator), by command line; not the session's
    emulator fork server (tests/conftest.py), started before the test."""
    out = subprocess.run(["ps", "-ww", "-o", "args=", "--ppid", str(os.getpid())], capture_output=True,
                         text=True).stdout
    forkserver = os.environ[FORKSERVER_ENV]
    return [line for line in out.splitlines()
            if not line.startswith("ps ") and "<defunct>" not in line and not line.endswith(forkserver)]


def sweep_in_process(*args: str) -> tuple[int, list[str], float]:
    """`hil sweep ARGS` through the CLI's main: exit code, stderr lines, seconds."""
    err, out = io.StringIO(), io.StringIO()
    started = time.perf_counter()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        try:
            code = main(["sweep", *args])
        except SystemExit as exc:  # argparse refusing a value of the wrong type
            code = int(exc.code or 0)
    return code, err.getvalue().splitlines(), time.perf_counter() - started


def assert_refused(args: list[str], says: str, names: str, out: Path) -> None:
    code, lines, elapsed = sweep_in_process(*args, *([] if "--out" in args else ["--out", str(out)]))
    text = "\n".join(lines)
    assert code == 2, text
    assert 1 <= len(lines) <= 20, text
    assert says in text, f"expected {says!r} in:\n{text}"
    assert names in lines[0], f"expected {names!r} named in:\n{text}"
    assert elapsed < LIMIT_S
    assert not out.exists() or out.is_file() or not any(out.iterdir())  # no results directory made
    assert children() == []


def test_the_corpus_covers_each_kind_of_mistake():
    names = {p.stem for p in CORPUS}
    assert len(names) + len(OPTIONS) >= 40
    assert {"alias_bomb", "nested_400_deep", "duplicate_vary_key", "uniform_high_to_low", "integers_high_to_low",
            "choice_empty", "override_unknown_field", "vary_unknown_field", "index_past_end",
            "cross_unknown_controller", "values_string_for_number", "override_string_for_number",
            "overrides_break_every_sample"} <= names


@pytest.mark.parametrize("path", CORPUS, ids=[p.stem for p in CORPUS])
def test_each_bad_sweep_file_is_refused_in_one_clear_line(path, tmp_path):
    names = "board_config_typo.yaml" if path.stem == "scenario_invalid" else path.name  # the base's own lines
    assert_refused([str(path)], expected(path), names, tmp_path / "out")


def _file(tmp_path: Path) -> Path:
    (tmp_path / "a_file").write_text("not a directory\n")
    return tmp_path / "a_file"


def _not_a_sweep(tmp_path: Path) -> Path:
    (tmp_path / "notes").mkdir()
    (tmp_path / "notes" / "todo.txt").write_text("x\n")
    return tmp_path / "notes"


# name -> (the options, made from tmp_path; what the message says; what its first line names)
OPTIONS: dict[str, tuple[Callable[[Path], list[str]], str, str]] = {
    "jobs_zero": (lambda _: ["--jobs", "0"], f"expected 1 to {max_jobs()}", "hil sweep: --jobs 0"),
    "jobs_negative": (lambda _: ["--jobs", "-3"], f"expected 1 to {max_jobs()}", "hil sweep: --jobs -3"),
    "jobs_100000": (lambda _: ["--jobs", "100000"], f"expected 1 to {max_jobs()}", "--jobs 100000"),
    "jobs_not_a_number": (lambda _: ["--jobs", "two"], "invalid int value: 'two'", "usage: hil sweep"),
    "limit_zero": (lambda _: ["--limit", "0"], "at least 1", "hil sweep: --limit 0"),
    "limit_negative": (lambda _: ["--limit", "-1"], "at least 1", "hil sweep: --limit -1"),
    "cluster_no_port": (lambda _: ["--cluster", "scheduler"], "expected a Dask scheduler address", "--cluster"),
    "cluster_http": (lambda _: ["--cluster", "http://127.0.0.1:8786"], "unknown protocol 'http'", "--cluster"),
    "cluster_port_99999": (lambda _: ["--cluster", "tcp://127.0.0.1:99999"], "port 99999 is not in 1-65535",
                           "--cluster"),
    "cluster_unresolvable": (lambda _: ["--cluster", "tcp://notahost.invalid:8786"], "cannot resolve host",
                             "--cluster tcp://notahost.invalid:8786"),
    "out_is_a_file": (lambda t: ["--out", str(_file(t))], "exists and is not a directory", "--out"),
    "out_below_a_file": (lambda t: ["--out", str(_file(t) / "sub")], "is a file", "--out"),
    "resume_not_a_sweep": (lambda t: ["--resume", "--out", str(_not_a_sweep(t))], "is not a sweep's results",
                           "hil sweep: --resume"),
    "resume_nowhere": (lambda t: ["--resume", "--out", str(t / "nowhere")], "nothing to resume", "--resume"),
}


@pytest.fixture
def good_sweep(tmp_path) -> Path:
    path = tmp_path / "good.yaml"
    path.write_text(f"name: good\nscenario: {SHORT_HOVER}\nsamples: 2\nvary:\n  seed: {{integers: [1, 100]}}\n")
    return path


@pytest.mark.parametrize("name", OPTIONS)
def test_each_bad_option_is_refused_in_one_line_naming_it(name, good_sweep, tmp_path):
    make, says, names = OPTIONS[name]
    assert_refused([str(good_sweep), *make(tmp_path)], says, names, tmp_path / "out")


def test_a_missing_or_unreadable_sweep_file_is_one_line(tmp_path):
    assert_refused([str(tmp_path / "nowhere.yaml")], "no such file", str(tmp_path / "nowhere.yaml"), tmp_path / "o")
    (tmp_path / "folder.yaml").mkdir()
    assert_refused([str(tmp_path / "folder.yaml")], "cannot read", "folder.yaml", tmp_path / "o")


def hil_sweep(*args: str) -> tuple[subprocess.CompletedProcess[str], float]:
    started = time.perf_counter()
    result = subprocess.run([sys.executable, "-m", "hil", "sweep", *args], capture_output=True, text=True,
                            cwd=ROOT, timeout=120)
    return result, time.perf_counter() - started


@pytest.mark.e2e
@pytest.mark.slow  # the 10 s connect timeout
def test_a_cluster_that_does_not_answer_is_exit_3_in_one_line_and_nothing_is_left(good_sweep, tmp_path):
    out = tmp_path / "out"
    address = f"tcp://127.0.0.1:{free_port()}"  # nothing listens there
    result, elapsed = hil_sweep(str(good_sweep), "--cluster", address, "--out", str(out))
    assert result.returncode == 3, result.stderr
    assert result.stderr.splitlines() == [f"hil sweep: --cluster {address}: no Dask scheduler answered within 10 s "
                                          f"(Timed out trying to connect to {address} after 10 s)"]
    assert elapsed < LIMIT_S and not out.exists() and children() == []


@pytest.mark.e2e
@pytest.mark.skipif(not Path("/usr/bin/time").is_file(), reason="needs /usr/bin/time (Debian package time)")
def test_the_alias_bomb_as_a_process_is_refused_in_bounded_memory(tmp_path):
    bomb = ROOT / "tests" / "data" / "bad_sweeps" / "alias_bomb.yaml"
    peak = tmp_path / "peak_kb"
    result = subprocess.run(["/usr/bin/time", "-o", str(peak), "-f", "%M", sys.executable, "-m", "hil", "sweep",
                             str(bomb), "--out", str(tmp_path / "out")], capture_output=True, text=True, cwd=ROOT,
                            timeout=60)
    assert result.returncode == 2 and result.stderr.splitlines() == [
        f"{bomb}:8: more than 100,000 YAML nodes with aliases expanded (an alias bomb?); a scenario or a sweep has "
        "a few hundred"]
    assert int(peak.read_text().split()[-1]) < 300_000  # the interpreter and its imports: ~70 MB; unbounded: 2.5 GB
