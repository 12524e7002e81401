"""Shared fixtures: the FMU built once per test session from the committed sources, PX4's builds unpacked once
(HIL_PX4_DIR), the foreign plant (tests/data/foreign_plant) exported by pythonfmu once, and each shipped scenario
flown once per session for every test that judges that flight. Emulators are forked by a warm server. Every test's
processes end with it, and they start with a terminal's signal dispositions however pytest was started."""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import shutil
import signal
import subprocess
from collections.abc import Callable, Iterator
from pathlib import Path

import psutil
import pytest

from firmware_interface.forkserver import FORKSERVER_ENV
from hil.boards.forked_emulator import emulator_forkserver
from plant_fmu.build import ensure_fmu
from tests.support.cli_runs import REPORTED, run
from tests.support.px4_builds import px4_build, px4_root

FOREIGN_PLANT = Path(__file__).parent / "data" / "foreign_plant"


def pytest_configure(config: pytest.Config) -> None:
    """A shell starts a background job (`make test &` in a script: job control off) with SIGINT and SIGQUIT
    ignored, and every process a test starts would inherit that: a test that stops a child with SIGINT, as a
    user's Ctrl-C does, would wait for nothing (measured: three tests timed out this way). The tests' children
    get a terminal's defaults instead (a Python handler is not inherited through exec)."""
    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    if signal.getsignal(signal.SIGQUIT) == signal.SIG_IGN:
        signal.signal(signal.SIGQUIT, signal.SIG_DFL)


@pytest.fixture(scope="session", autouse=True)
def warm_emulators() -> Iterator[None]:
    """Every emulator the tests start, in process or by a `hil run` they start, forked by one warm fork server per
    test process: ~0.8 s of CPU less for each of the suite's ~180 (docs/performance.md, eleventh stop). Tests of
    the fresh process's own life ask for `fresh_emulators`."""
    with emulator_forkserver():
        yield


@pytest.fixture
def fresh_emulators(monkeypatch: pytest.MonkeyPatch) -> None:
    """Emulators started as `hil run` starts them with no fork server: a fresh process, the bench's child, its
    arguments on its command line (for tests that find it by them, or by its parent)."""
    monkeypatch.delenv(FORKSERVER_ENV)


@pytest.fixture(autouse=True)
def no_process_left_behind() -> Iterator[None]:
    """What a test started and left running (a bench, a subscriber, a board of a test that failed halfway) is
    killed after it with everything it started, so it cannot load the machine or hold a port for the tests after
    it. Processes of wider fixtures are started before this snapshot and kept."""
    me = psutil.Process()
    before = {child.pid for child in me.children(recursive=True)}
    yield
    left = [child for child in me.children(recursive=True) if child.pid not in before]
    for child in left:
        with contextlib.suppress(psutil.NoSuchProcess):
            child.kill()
    psutil.wait_procs(left, timeout=10)


@pytest.fixture(scope="session")
def fmu_path() -> Path:
    return ensure_fmu()


@pytest.fixture(scope="session")
def sitl(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A px4_sitl_default build from HIL_PX4_DIR (unpacked once per session)."""
    return px4_build(px4_root(), "sitl", tmp_path_factory.mktemp("px4"))


@pytest.fixture(scope="session")
def hitl(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A px4_sitl_nolockstep build from HIL_PX4_DIR (unpacked once per session)."""
    return px4_build(px4_root(), "hitl", tmp_path_factory.mktemp("px4"))


@pytest.fixture(scope="session")
def foreign_mapping(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The quadrotor of tests/data/foreign_plant/enu_quadrotor.py exported by pythonfmu, its mapping beside it."""
    from pythonfmu.builder import FmuBuilder

    out = tmp_path_factory.mktemp("foreign_plant")
    FmuBuilder.build_FMU(FOREIGN_PLANT / "enu_quadrotor.py", dest=out)
    shutil.copy(FOREIGN_PLANT / "enu_quadrotor.yaml", out)
    return out / "enu_quadrotor.yaml"


@pytest.fixture(scope="session")
def shipped_flight(tmp_path_factory) -> Callable[[Path], tuple[subprocess.CompletedProcess[str], Path]]:
    """A shipped scenario flown once (as a user runs it: `hil run FILE`), its process and run directory. Once per
    test session, not per pytest-xdist worker: the first worker to need a flight flies it under a file lock in the
    session's shared temporary directory, and the other reads that run (tests in five files read the same flights,
    and two workers flew them twice: ~2 min of CPU)."""
    shared = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        shared = shared.parent  # pytest-N/popen-gwK: the session's directory, one for its workers
    flights: dict[Path, tuple[subprocess.CompletedProcess[str], Path]] = {}

    def flight(scenario: Path) -> tuple[subprocess.CompletedProcess[str], Path]:
        if scenario not in flights:
            home = shared / "shipped-flights" / scenario.stem
            home.mkdir(parents=True, exist_ok=True)
            with open(home.parent / f"{scenario.stem}.lock", "w") as lock:
                fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes, or the worker dies
                flights[scenario] = flown_before(home) or fly_shipped(scenario, home)
        return flights[scenario]

    return flight


def fly_shipped(scenario: Path, home: Path) -> tuple[subprocess.CompletedProcess[str], Path]:
    # no ground-station relay: a GCS answering on UDP 14550 (another run, QGroundControl) would inject
    # commands, and their ACKs would be recorded
    options = ("--no-gcs",) if scenario.stem == REPORTED else ("--no-gcs", "--no-report")
    result, run_dir = run(scenario, home / "runs", *options)
    process = {"args": result.args, "returncode": result.returncode, "stdout": result.stdout, "stderr": result.stderr}
    (home / "process.json").write_text(json.dumps({**process, "run_dir": str(run_dir)}))
    return result, run_dir


def flown_before(home: Path) -> tuple[subprocess.CompletedProcess[str], Path] | None:
    """The flight another worker of this session made, as it left it; None if none did."""
    if not (home / "process.json").exists():
        return None
    process = json.loads((home / "process.json").read_text())
    run_dir = Path(process.pop("run_dir"))
    return subprocess.CompletedProcess(**process), run_dir
