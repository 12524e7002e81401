"""What a pytest session asked of the bench: its options (`--hil-board`, `--hil-controller`, ...) and ini keys read
once, the boards named and checked, so that a wrong name stops the session before anything is collected."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import pytest

if TYPE_CHECKING:
    from hil.boards.target import BoardTarget

REPORTS = ("all", "failed", "none")  # which runs get report.html


@dataclass(frozen=True)
class Board:
    """A board as a test names it: the spec the user wrote (`emulator`, `px4:DIR`, `px4-hitl:DIR`,
    `port:CONNECTION`), the short form item ids carry, and the board kind it names."""

    spec: str
    id: str
    target: BoardTarget

    @classmethod
    def named(cls, spec: str, option: str = "board", item_id: str | None = None) -> Board:
        """The board `spec` names; ValueError (BoardSpecError) in one line for a wrong one."""
        from hil.boards.registry import BoardOptions, board_target

        return cls(spec, item_id or spec.partition(":")[0], board_target(spec, BoardOptions(named_by=option)))


@dataclass(frozen=True)
class HilSettings:
    collects: bool  # scenario and sweep files are test items (--hil, or `hil = true` in the ini file)
    boards: tuple[Board, ...]  # each item flies on each; the first is what hil_run flies on by default
    controllers: tuple[str, ...]  # emulator controllers a scenario file's items fly (none: the scenario's own)
    seed: int | None  # a scenario file's seed replaced
    runs_root: Path
    limit: int | None  # a sweep file's first samples only
    report: str  # one of REPORTS
    telemetry: bool  # publish each run on Zenoh (off: no Zenoh session at all)
    px4_dir: Path | None  # the PX4 build or packages hil_px4 flies


_KEY = pytest.StashKey[HilSettings]()


def collects(config: pytest.Config) -> bool:
    """Whether the session asked for scenario files as tests; cheap, read before anything of the bench loads."""
    return bool(config.getoption("hil") or config.getini("hil"))


def settings_of(config: pytest.Config) -> HilSettings:
    """The session's settings, read and checked on first use."""
    if _KEY not in config.stash:
        config.stash[_KEY] = _read(config)
    return config.stash[_KEY]


def _read(config: pytest.Config) -> HilSettings:
    limit = config.getoption("hil_limit")
    if limit is not None and limit < 1:
        raise pytest.UsageError(f"--hil-limit {limit}: expected a number of samples, at least 1")
    return HilSettings(collects(config), _boards(config.getoption("hil_board") or config.getini("hil_board")),
                       _controllers(config.getoption("hil_controller") or []), config.getoption("hil_seed"),
                       _path(config, "hil_runs") or config.invocation_params.dir / "runs", limit,
                       config.getoption("hil_report") or "all", bool(config.getoption("hil_telemetry")),
                       _path(config, "hil_px4"))


def _path(config: pytest.Config, name: str) -> Path | None:
    """A path option: from the command line relative to where pytest started, from the ini file relative to it."""
    given = config.getoption(name)
    if given:
        return config.invocation_params.dir / given
    listed = config.getini(name)
    return Path(listed[0]) if listed else None


def _controllers(given: list[str]) -> tuple[str, ...]:
    """The controllers of --hil-controller (repeated, or comma-separated), each checked, in order, once each."""
    from firmware_interface.emulator.control.registry import CONTROLLERS

    controllers = tuple(dict.fromkeys(c.strip() for text in given for c in text.split(",")))
    unknown = [c for c in controllers if c not in CONTROLLERS]
    if unknown:
        raise pytest.UsageError(f"--hil-controller {','.join(controllers)}: unknown controller(s) "
                                f"{', '.join(c or repr(c) for c in unknown)}; "
                                f"expected {', '.join(CONTROLLERS)}")
    return controllers


def _boards(given: list[str]) -> tuple[Board, ...]:
    """The boards named (the emulator when none is), each checked; ids are the scheme (`emulator`, `px4`), or the
    whole spec where two boards share one."""
    specs = list(dict.fromkeys(given or ["emulator"]))
    schemes = [spec.partition(":")[0] for spec in specs]
    try:
        return tuple(Board.named(spec, "--hil-board", scheme if schemes.count(scheme) == 1 else spec)
                     for spec, scheme in zip(specs, schemes, strict=True))
    except ValueError as exc:
        raise pytest.UsageError(str(exc)) from None


def run_subdir(nodeid: str) -> Path:
    """Where a test's run directories go below the runs root: its node id as a path, in characters a shell glob
    and every CI's artefact upload take (`scenarios/hover.yaml::hover[smpid]` -> scenarios/hover.yaml/hover-smpid)."""
    parts = re.split(r"::|/", nodeid.replace("[", "-").replace("]", ""))
    return Path(*(re.sub(r"[^A-Za-z0-9_.+-]", "_", part) or "_" for part in parts if part not in ("", ".", "..")))
