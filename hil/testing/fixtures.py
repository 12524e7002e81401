"""Fixtures for a user's own tests: `hil_run` flies a scenario and returns the run as objects; `hil_emulator` and
`hil_px4` name a board once for a module.

Neither board stays up between flights: each flight starts its own emulator or PX4 and stops it, as `hil run`
does. A board kept up would carry the last flight into the next (the emulator's estimator, its landed state and its
clock; PX4's lockstep clock, which never goes back, its EKF and its parameters), so a test's verdict would depend on
the tests before it, and lockstep runs would no longer repeat bit for bit. What keeping one up would take is in
docs/ci.md; what these fixtures do once per module is what a flight does not have to repeat: the plant FMU built,
the PX4 package found and unpacked.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest

from hil.testing.settings import Board, run_subdir, settings_of

if TYPE_CHECKING:
    from hil.scenario.schema import Scenario
    from hil.testing.results import HilRun


@pytest.fixture
def hil_run(request: pytest.FixtureRequest) -> Callable[..., HilRun]:
    """`hil_run(scenario, board=None, controller=None, seed=None, overrides=None) -> HilRun`: fly a scenario (a file,
    or a `Scenario`) on a board (a `hil_emulator`/`hil_px4` board or a spec; default: the first --hil-board),
    fields replaced by their path (`overrides={"duration_s": 5}`). Returns the run whether it passed its
    expectations or not (`run.passed`); a scenario that cannot fly, or a run that ends without a verdict on the
    flight (a board failure, a bench bug), fails the test with the reason. Run directories go under
    --hil-runs/<the test's id>/."""
    settings = settings_of(request.config)
    directory = settings.runs_root / run_subdir(request.node.nodeid)

    def fly_scenario(scenario: str | os.PathLike[str] | Scenario, *, board: Board | str | None = None,
                     controller: str | None = None, seed: int | None = None,
                     overrides: Mapping[str, Any] | None = None) -> HilRun:
        from hil.exit_codes import EXIT_EXPECT_FAILED, EXIT_OK
        from hil.testing.flight import fly, load, with_changes
        from hil.testing.results import HilRunError, error_text

        changes = {**(overrides or {}), **({"seed": seed} if seed is not None else {}),
                   **({"board.controller": controller} if controller else {})}
        try:
            chosen = board if isinstance(board, Board) else Board.named(board) if board else settings.boards[0]
            loaded = load(Path(scenario)) if isinstance(scenario, (str, os.PathLike)) else scenario
            flown = with_changes(loaded, changes, "hil_run")
        except (HilRunError, ValueError) as exc:
            problems = str(exc)  # reported below, outside the handler: pytest would show both exceptions
        else:
            problems = ""
        if problems:
            pytest.fail(problems, pytrace=False)
        run = fly(flown, chosen, directory, settings)
        if run.exit_code not in (EXIT_OK, EXIT_EXPECT_FAILED):
            pytest.fail(error_text(run), pytrace=False)
        return run

    return fly_scenario


@pytest.fixture(scope="module")
def hil_emulator() -> Board:
    """The built-in emulator, for `hil_run(..., board=hil_emulator)`: the plant FMU is built (if its sources
    changed) before the module's first flight; each flight starts its own emulator on a fresh pty."""
    from plant_fmu.build import ensure_fmu

    ensure_fmu()
    return Board.named("emulator")


@pytest.fixture(scope="session")
def _hil_px4_build(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The PX4 SITL build of --hil-px4 (or `hil_px4` in the ini file), found once per session: a build directory
    (`bin/px4`), PX4-Autopilot's `build/` with `px4_sitl_default`, or a directory with a `px4-sitl-*.tar.gz`
    package, unpacked here."""
    from hil.boards.px4.build import Px4SetupError, find_build

    root = settings_of(request.config).px4_dir
    if root is None:
        pytest.skip("hil_px4: no PX4 build given (--hil-px4 DIR, or hil_px4 in the ini file)")
    if (root / "bin" / "px4").is_file():
        return root
    try:
        return find_build(root, "sitl", tmp_path_factory.mktemp("px4"))
    except (Px4SetupError, OSError) as exc:
        pytest.fail(f"--hil-px4 {root}: {exc}", pytrace=False)


@pytest.fixture(scope="module")
def hil_px4(_hil_px4_build: Path) -> Board:
    """PX4 SITL from --hil-px4, for `hil_run(..., board=hil_px4)`; skipped without one. Each flight starts its own
    PX4 on a free instance and stops it."""
    try:
        return Board.named(f"px4:{_hil_px4_build}", "--hil-px4")
    except ValueError as exc:
        pytest.fail(str(exc), pytrace=False)
