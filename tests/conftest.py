"""Shared fixtures: the FMU built once per test session from the committed sources, and each shipped
scenario flown once per session for every test that judges that flight."""

from __future__ import annotations

import subprocess
from collections.abc import Callable
from pathlib import Path

import pytest

from plant_fmu.build import ensure_fmu
from tests.support.cli_runs import run


@pytest.fixture(scope="session")
def fmu_path() -> Path:
    return ensure_fmu()


@pytest.fixture(scope="session")
def shipped_flight(tmp_path_factory) -> Callable[[Path], tuple[subprocess.CompletedProcess[str], Path]]:
    """A shipped scenario flown once (as a user runs it: `hil run FILE`), its process and run directory."""
    flights: dict[Path, tuple[subprocess.CompletedProcess[str], Path]] = {}

    def flight(scenario: Path) -> tuple[subprocess.CompletedProcess[str], Path]:
        if scenario not in flights:
            # no ground-station relay: a GCS answering on UDP 14550 (another run, QGroundControl) would inject
            # commands, and their ACKs would be recorded
            flights[scenario] = run(scenario, tmp_path_factory.mktemp(scenario.stem), "--no-gcs")
        return flights[scenario]

    return flight
