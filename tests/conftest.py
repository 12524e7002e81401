"""Shared fixtures: the FMU is built once per test session from the committed sources."""

from __future__ import annotations

from pathlib import Path

import pytest

from plant_fmu.build import ensure_fmu


@pytest.fixture(scope="session")
def fmu_path() -> Path:
    return ensure_fmu()
