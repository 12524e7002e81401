"""The PX4 options' failure paths, which need no PX4 build: a PX4 that is not there, a directory that is not
a PX4 build. (The flights themselves are in test_px4.py.)"""

from __future__ import annotations

import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.support.ports import free_port
from tests.support.summary_text import summary_field

pytestmark = pytest.mark.e2e  # drives the bench's processes (hil, the emulator) end to end

ROOT = Path(__file__).resolve().parent.parent


def hil_run(*args: str, runs: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "hil", "run", "--no-report", *args,
                           "--runs", str(runs), "--no-telemetry"],
                          capture_output=True, text=True, timeout=120, cwd=ROOT)


def test_a_px4_sitl_that_is_not_running_gets_a_sitl_error(tmp_path):
    started = time.monotonic()
    result = hil_run("scenarios/hover.yaml", "--port", f"tcpin:127.0.0.1:{free_port()}", "--mavlink",
                     f"udpout:127.0.0.1:{free_port(socket.SOCK_DGRAM)}", "--connect-timeout", "2", runs=tmp_path)
    assert result.returncode == 3
    assert time.monotonic() - started < 15
    ended = [summary_field(result.stdout, "ended")]
    assert len(ended) == 1 and "PX4 SITL" in ended[0] and "SYS_HITL" not in ended[0]


def test_a_directory_without_px4_is_bad_input(tmp_path):
    result = hil_run("scenarios/hover.yaml", "--px4", str(tmp_path), runs=tmp_path / "runs")
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1 and "bin/px4" in result.stderr
    assert not (tmp_path / "runs").exists()
