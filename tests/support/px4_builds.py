"""Where the PX4 tests find real PX4: `HIL_PX4_DIR`, a directory holding either PX4's build directories
(`px4_sitl_default`, `px4_sitl_nolockstep`, as in PX4-Autopilot/build) or the packed builds
(`px4-sitl-*.tar.gz`, `px4-hitl-nolockstep-*.tar.gz`), which are unpacked once per test session.

Unset: the PX4 tests are skipped with one line saying so. Set but unusable: they fail (CI sets it).
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from hil.boards.px4.build import Px4SetupError, find_build

ENV = "HIL_PX4_DIR"
SKIP_REASON = (f"real-PX4 tests skipped: set {ENV} to PX4-Autopilot/build (with px4_sitl_default and "
               "px4_sitl_nolockstep built) or to a directory with the PX4 .tar.gz packages")


def px4_root() -> Path:
    """The directory HIL_PX4_DIR names; called at module level, so an unset variable skips the whole
    module with one line."""
    value = os.environ.get(ENV)
    if not value:
        pytest.skip(SKIP_REASON, allow_module_level=True)
    return Path(value).resolve()


def px4_build(root: Path, kind: str, scratch: Path) -> Path:
    if not root.is_dir():
        pytest.fail(f"{ENV}={root}: no such directory")
    try:
        return find_build(root, kind, scratch)
    except Px4SetupError as exc:
        pytest.fail(f"{ENV}={root}: {exc}")
