"""`hil run` as a user types it, from the repository root, for the end-to-end tests."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
# The shipped flight that also writes its report.html, as `hil run FILE` does by default: the page is the same code
# whatever the scenario (tests/test_report_html.py draws gust's and the paper helix's in Chromium), and drawing it
# takes seconds of every flight that does
REPORTED = "hover"


def run(scenario: Path, runs: Path, *extra: str, timeout: float = 600) -> tuple[subprocess.CompletedProcess[str], Path]:
    """The finished process and its run directory (the newest in `runs`)."""
    result = subprocess.run([sys.executable, "-m", "hil", "run", str(scenario), "--runs", str(runs), *extra],
                            capture_output=True, text=True, cwd=ROOT, timeout=timeout)
    return result, max(runs.iterdir())


def wait_flying(runs: Path, then_s: float = 1.0, timeout_s: float = 60.0) -> None:
    """Until frames flow between the bench and its emulator (the run's link.tlog has its first 64 KiB block:
    ~1 s simulated), then `then_s` more: with 1 s, past the preflight (~2.5 s simulated, at several times real
    time) and in the air."""
    deadline = time.monotonic() + timeout_s
    while not frames_flowed(runs):
        assert time.monotonic() < deadline, f"no MAVLink frame in {runs} after {timeout_s:g} s"
        time.sleep(0.05)
    time.sleep(then_s)


def frames_flowed(runs: Path) -> bool:
    """A run under `runs` has stepped (its link.tlog has its first 64 KiB block: ~1 s simulated)."""
    return any(p.stat().st_size > 0 for p in runs.glob("*/link.tlog"))


def emulator_pids(bench_pid: int) -> list[int]:
    """The bench's emulator process, by its command line: not just any child, because the bench's own start-up
    runs short-lived ones (fmpy's import runs `ldconfig -p`, through ctypes.util.find_library)."""
    out = subprocess.run(["ps", "-o", "pid=,args=", "--ppid", str(bench_pid)], capture_output=True, text=True).stdout
    return [int(line.split(None, 1)[0]) for line in out.splitlines() if "firmware_interface.emulator" in line]
