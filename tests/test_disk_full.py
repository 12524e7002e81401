"""A run whose disk fills: `hil run` on a small tmpfs stops the flight at the first write that fails, says in one
line that the disk is full and where, writes summary.txt and metrics.json, leaves a recording `hil recover`
rebuilds (once there is room: a copy elsewhere), stops the board, prints no Python or Rust backtrace, and exits
with 5 (docs/architecture.md, "How a run ends"). The filesystems need mount(8) as root; elsewhere the tests skip.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap.writer import Writer

from hil.outputs.disk import RESERVE_NAME, partial_record_start

ROOT = Path(__file__).resolve().parent.parent
BACKTRACES = ("Traceback", "panicked", "stack backtrace", "error logging message", "Failed to close")


def _mount(folder: Path, size: str) -> None:
    folder.mkdir()
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(folder)],
                             capture_output=True, text=True)
    if mounted.returncode != 0:
        pytest.skip(f"a small filesystem needs mount(8) as root: {mounted.stderr.strip() or 'not allowed'}")


@pytest.fixture
def small_disk(tmp_path) -> Iterator[Path]:
    """A 3 MB filesystem: a run fills it in ~10 s of flight (~440 kB/s of recording plus the tlog), after the
    first 1 MiB chunk of the recording is on it."""
    folder = tmp_path / "small"
    _mount(folder, "3m")
    yield folder
    subprocess.run(["umount", str(folder)], check=True)


def _emulators_on(folder: Path) -> list[str]:
    out = subprocess.run(["ps", "-eo", "args="], capture_output=True, text=True).stdout
    return [line for line in out.splitlines() if "firmware_interface.emulator" in line and str(folder) in line]


@pytest.mark.usefixtures("fresh_emulators")
@pytest.mark.e2e
@pytest.mark.slow
def test_a_run_that_fills_its_disk_stops_cleanly_and_stays_recoverable(small_disk, tmp_path):
    result = subprocess.run([sys.executable, "-m", "hil", "run", str(ROOT / "scenarios" / "gust.yaml"), "--runs",
                             str(small_disk / "runs"), "--no-telemetry", "--no-gcs"], capture_output=True, text=True,
                            cwd=ROOT, timeout=300)
    output = result.stdout + result.stderr
    assert result.returncode == 5, output
    assert not any(marker in output for marker in BACKTRACES), output
    assert len(output.splitlines()) <= 20
    (run_dir,) = (small_disk / "runs").iterdir()
    metrics = json.loads((run_dir / "metrics.json").read_text())
    assert metrics["exit_code"] == 5 and metrics["reason"] == (
        f"disk full: no space left on {small_disk} writing recording.mcap; the flight was stopped (hil recover the "
        "run directory to read its recording)")
    assert f"ended: {metrics['reason']}" in " ".join(result.stdout.split())  # the summary wraps it at 100 columns
    assert "result: ABORTED (exit 5)" in (run_dir / "summary.txt").read_text()
    assert not (run_dir / RESERVE_NAME).exists() and _emulators_on(small_disk) == []
    flown_s = metrics["timing"]["sim_s"]
    assert 3 < flown_s < 60  # stopped by the disk, well before the 60 s mission's end

    copy = tmp_path / "copy"  # the full disk has no room for the rebuilt file
    shutil.copytree(run_dir, copy)
    recovered = subprocess.run([sys.executable, "-m", "hil", "recover", str(copy)], capture_output=True, text=True,
                               cwd=ROOT, timeout=120)
    assert recovered.returncode == 0, recovered.stderr
    with open(copy / "recording.mcap", "rb") as file:
        times = [message.log_time for _, _, message in make_reader(file).iter_messages(log_time_order=False)]
    span_s = (max(times) - min(times)) * 1e-9
    # everything up to the last whole 1 MiB chunk: at most one chunk (~2.3 s at 440 kB/s) is lost
    assert flown_s - 3.0 < span_s <= flown_s + 0.01, (span_s, flown_s)


def test_no_room_for_a_run_directory_starts_nothing(tmp_path):
    from hil.app.cli import main

    folder = tmp_path / "tiny"
    _mount(folder, "64k")
    try:
        subprocess.run(["dd", "if=/dev/zero", f"of={folder / 'filler'}", "bs=4k"], capture_output=True)  # fill it
        code = main(["run", str(ROOT / "tests" / "data" / "short_hover.yaml"), "--runs", str(folder / "runs"),
                     "--no-telemetry"])
        assert code == 5
        assert not (folder / "runs").exists() or list((folder / "runs").iterdir()) == []
    finally:
        subprocess.run(["umount", str(folder)], check=True)


def test_a_record_cut_short_is_found_by_its_header(tmp_path):
    path = tmp_path / "r.mcap"
    with open(path, "wb") as file:  # a file being written: whole records, no summary and closing magic yet
        writer = Writer(file, use_chunking=False)
        writer.start()
        channel = writer.register_channel("t", "json", writer.register_schema("s", "jsonschema", b"{}"))
        for i in range(100):
            writer.add_message(channel, i, b"{}", i)
    whole = path.stat().st_size
    assert partial_record_start(path) is None
    with open(path, "ab") as file:  # a chunk record whose body was cut after 10 of its 5000 bytes
        file.write(bytes([0x06]) + (5000).to_bytes(8, "little") + bytes(10))
    assert partial_record_start(path) == whole
    finished = tmp_path / "finished.mcap"
    with open(finished, "wb") as file:
        writer = Writer(file)
        writer.start()
        writer.finish()
    assert partial_record_start(finished) is None  # a finished file ends with its magic, not a record
