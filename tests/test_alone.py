"""`make test`'s two workers: tests overlap, except an `alone` one (tests/support/alone.py), measured on a real
pytest-xdist session of sleeping tests that write down when they ran."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

CONFTEST = '''
import pytest
from tests.support.alone import room

@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    with room(item.config, alone=item.get_closest_marker("alone") is not None):
        yield
'''

SLEEPERS = '''
import json, time
import pytest

def ran(name, log):
    started = time.monotonic()
    time.sleep(0.4)
    with open(log, "a") as out:
        out.write(json.dumps([name, started, time.monotonic()]) + "\\n")

@pytest.mark.parametrize("n", range(6))
def test_beside(n):
    ran(f"beside{n}", LOG)

@pytest.mark.alone
@pytest.mark.parametrize("n", range(2))
def test_alone(n):
    ran(f"alone{n}", LOG)
'''


def test_an_alone_test_overlaps_no_other_while_the_others_run_two_at_a_time(tmp_path):
    log = tmp_path / "ran.jsonl"
    (tmp_path / "conftest.py").write_text(CONFTEST)
    (tmp_path / "test_sleepers.py").write_text(f"LOG = {str(log)!r}\n" + SLEEPERS)
    result = subprocess.run([sys.executable, "-m", "pytest", "-q", "-n", "2", "-p", "no:cacheprovider",
                             "--rootdir", str(tmp_path), "-o", "markers=alone: by itself", str(tmp_path)],
                            capture_output=True, text=True, cwd=tmp_path, timeout=120,
                            env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"})
    assert result.returncode == 0, result.stdout + result.stderr
    spans = [json.loads(line) for line in log.read_text().splitlines()]
    assert len(spans) == 8

    def overlap(a: list, b: list) -> bool:
        return a is not b and a[1] < b[2] and b[1] < a[2]

    alone = [s for s in spans if s[0].startswith("alone")]
    assert all(not overlap(a, other) for a in alone for other in spans)
    beside = [s for s in spans if s[0].startswith("beside")]
    assert any(overlap(a, b) for a in beside for b in beside)  # the others did run two at a time
