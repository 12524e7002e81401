"""Shared fixtures: the FMU built once per test session from the committed sources, PX4's builds unpacked once
(HIL_PX4_DIR), the foreign plant (tests/data/foreign_plant) exported by pythonfmu once, and each shipped scenario
flown once per session for every test that judges that flight."""

from __future__ import annotations

import shutil
import subprocess
from collections.abc import Callable
from pathlib import Path

import pytest

from plant_fmu.build import ensure_fmu
from tests.support.cli_runs import REPORTED, run
from tests.support.px4_builds import px4_build, px4_root

FOREIGN_PLANT = Path(__file__).parent / "data" / "foreign_plant"


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
    """A shipped scenario flown once (as a user runs it: `hil run FILE`), its process and run directory."""
    flights: dict[Path, tuple[subprocess.CompletedProcess[str], Path]] = {}

    def flight(scenario: Path) -> tuple[subprocess.CompletedProcess[str], Path]:
        if scenario not in flights:
            # no ground-station relay: a GCS answering on UDP 14550 (another run, QGroundControl) would inject
            # commands, and their ACKs would be recorded
            options = ("--no-gcs",) if scenario.stem == REPORTED else ("--no-gcs", "--no-report")
            flights[scenario] = run(scenario, tmp_path_factory.mktemp(scenario.stem), *options)
        return flights[scenario]

    return flight
