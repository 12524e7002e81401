"""The pytest plugin, loaded by pytest in every session of an environment where hil-bench is installed (entry point
`hil` in the `pytest11` group; `-p no:hil` leaves it out). It collects nothing unless the session asks: `--hil`,
or `hil = true` in the ini file (`[tool.pytest.ini_options]` of pyproject.toml). Then every scenario and sweep YAML
file under the paths given is a test: `pytest --hil scenarios/ --junitxml=results.xml`. Its fixtures (`hil_run`,
`hil_emulator`, `hil_px4`) are there for any test that asks for them. Nothing of the bench but its exit codes is
imported until then.
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path

import pytest

from hil.testing.collect import YAML_SUFFIXES, collect_file
from hil.testing.fixtures import _hil_px4_build, hil_emulator, hil_px4, hil_run
from hil.testing.settings import REPORTS, collects, settings_of

__all__ = ["_hil_px4_build", "hil_emulator", "hil_px4", "hil_run"]  # pytest finds fixtures among the plugin's names


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("hil", "hil-bench: scenarios as test cases")
    group.addoption("--hil", action="store_true", help="collect scenario and sweep YAML files as tests")
    group.addoption("--hil-board", action="append", metavar="SPEC",
                    help="the board each item flies on: emulator (default), px4:DIR, px4-hitl:DIR, port:CONNECTION; "
                         "repeat it for one item per board")
    group.addoption("--hil-controller", action="append", metavar="NAME[,NAME]",
                    help="the emulator's controller for scenario files (one item per controller given)")
    group.addoption("--hil-seed", type=int, metavar="N", help="replace the seed of scenario files")
    group.addoption("--hil-runs", metavar="DIR", help="where run directories go (default runs/)")
    group.addoption("--hil-limit", type=int, metavar="N", help="only the first N samples of each sweep file")
    group.addoption("--hil-report", choices=REPORTS, help="which runs get report.html (default all)")
    group.addoption("--hil-telemetry", action="store_true",
                    help="publish each run on Zenoh (hil watch); off by default")
    group.addoption("--hil-px4", metavar="DIR", help="the PX4 SITL build (or package directory) hil_px4 flies")
    parser.addini("hil", type="bool", default=False, help="collect scenario and sweep YAML files as tests")
    parser.addini("hil_board", type="linelist", help="default boards (as --hil-board)")
    parser.addini("hil_runs", type="paths", help="default run directory root (as --hil-runs), from the ini file's "
                                                "directory")
    parser.addini("hil_px4", type="paths", help="default PX4 build for hil_px4 (as --hil-px4), from the ini file's "
                                               "directory")


def pytest_configure(config: pytest.Config) -> None:
    """A session that collects scenarios checks its options now: a wrong board or controller is a usage error.
    Where its items fly on the emulator, a warm fork server starts their emulators for the whole session (each
    pytest-xdist worker its own, unless one is named already): ~0.8 s of CPU less per item
    (`firmware_interface.forkserver`)."""
    if collects(config):
        from firmware_interface.forkserver import FORKSERVER_ENV

        settings = settings_of(config)
        xdist_controller = bool(getattr(config.option, "numprocesses", None)) and not hasattr(config, "workerinput")
        emulated = any(board.id.startswith("emulator") for board in settings.boards)
        if emulated and not xdist_controller and not os.environ.get(FORKSERVER_ENV):
            from hil.boards.forked_emulator import emulator_forkserver

            server = contextlib.ExitStack()
            server.enter_context(emulator_forkserver())
            config.add_cleanup(server.close)


def pytest_collect_file(file_path: Path, parent: pytest.Collector) -> pytest.Collector | None:
    if file_path.suffix in YAML_SUFFIXES and collects(parent.config):
        return collect_file(file_path, parent)
    return None


def pytest_report_header(config: pytest.Config) -> list[str]:
    if not collects(config):
        return []
    settings = settings_of(config)
    return [f"hil-bench: scenarios fly on {', '.join(b.spec for b in settings.boards)}; run directories under "
            f"{settings.runs_root}"]
