"""Scenario and sweep files as pytest items: a scenario file gives one item per board and controller asked for, a
sweep file one per sample (the first `--hil-limit`) per board. Each item flies in its setup and judges in its call,
so that pytest reports a flight that missed its expectations as a failure, and a run that could not judge the
flight (a bad scenario, a board that failed, a bench bug) as an error."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import pytest
import yaml

from hil.testing.results import HilRunError
from hil.testing.settings import Board, HilSettings, run_subdir, settings_of

if TYPE_CHECKING:
    from hil.scenario.schema import Scenario
    from hil.testing.results import HilRun

YAML_SUFFIXES = (".yaml", ".yml")


def _top_keys(path: Path) -> list[str] | None:
    """The keys of the file's top-level mapping ([] for anything else); None when it is not YAML the scenario
    loader reads (broken, a duplicate key, an alias bomb: read within the loader's bounds)."""
    from hil.scenario.loader import ScenarioError, read_yaml

    try:
        data = read_yaml(path)[1]
    except ScenarioError:
        return None
    return [str(key) for key in data] if isinstance(data, dict) else []


def file_kind(path: Path, named: bool) -> str | None:
    """"sweep", "scenario" or None (not ours). A file named on the command line is always ours; one found in a
    directory is a sweep when it has `scenario` and at least half its keys are sweep fields, a scenario when at
    least half its keys are scenario fields (a workflow's `name`, `on`, `jobs` is not), and a YAML file the loader
    refuses is taken as a broken scenario (it would otherwise drop out of the suite unseen)."""
    from hil.scenario.loader import MAX_BYTES
    from hil.scenario.schema import Scenario
    from hil.sweep.spec import SweepSpec

    if path.stat().st_size > MAX_BYTES:  # nobody's scenario
        return "scenario" if named else None
    keys = _top_keys(path)
    if keys is None:
        return "scenario"
    if "scenario" in keys and 2 * sum(k in SweepSpec.model_fields for k in keys) >= len(keys):
        return "sweep"
    fields = sum(k in Scenario.model_fields for k in keys)
    return "scenario" if named or (fields and 2 * fields >= len(keys)) else None


class Source(Protocol):
    """Where an item's scenario comes from."""

    controller: str | None  # the controller it flies, for `-k` (None: not known)

    def load(self, directory: Path) -> Scenario:
        """The scenario, or HilRunError naming file and field; `directory` takes any file it writes."""


@dataclass
class FileSource:
    """A scenario file, loaded when collected (for its controller) and kept, problems and all."""

    path: Path
    controller: str | None = None
    _loaded: Scenario | HilRunError | None = None

    def __post_init__(self) -> None:
        from hil.testing.flight import load

        try:
            scenario = load(self.path)
        except HilRunError as exc:
            self._loaded = exc
        else:
            self._loaded, self.controller = scenario, scenario.board.controller

    def load(self, directory: Path) -> Scenario:
        if isinstance(self._loaded, HilRunError):
            raise self._loaded
        assert self._loaded is not None, "loaded when collected"
        return self._loaded


@dataclass
class SampleSource:
    """A sweep's sample: its scenario written beside its run directory (`hil run` flies it again from there) and
    loaded from that file, so that a sample the schema refuses names the file, the line and the field."""

    sweep: Path
    index: int
    data: dict[str, Any]
    controller: str | None = field(init=False)

    def __post_init__(self) -> None:
        from hil.scenario.schema import Scenario

        board = self.data.get("board")
        chosen = board.get("controller") if isinstance(board, dict) else None
        self.controller = chosen or Scenario.model_fields["board"].default.controller

    def load(self, directory: Path) -> Scenario:
        from hil.testing.flight import load

        directory.mkdir(parents=True, exist_ok=True)
        path = directory / f"{self.data.get('name', 'sample')}.yaml"
        path.write_text(yaml.safe_dump(self.data, sort_keys=False))
        try:
            return load(path)
        except HilRunError as exc:
            raise HilRunError(f"sample {self.index} of {self.sweep}, written to {path}:\n{exc}") from None


@dataclass
class Unusable:
    """A file that gives no scenario at all (a sweep file or base the bench refuses): its problems."""

    problems: str
    controller: str | None = None

    def load(self, directory: Path) -> Scenario:
        raise HilRunError(self.problems)


class HilItem(pytest.Item):
    """One flight of one scenario on one board."""

    def __init__(self, *, source: Source, board: Board, changes: dict[str, Any], **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.source, self.board, self.changes = source, board, changes
        self.run: HilRun | None = None
        self.extra_keyword_matches.update(k for k in (changes.get("board.controller") or source.controller,
                                                      board.id) if k)

    def setup(self) -> None:
        from hil.exit_codes import EXIT_EXPECT_FAILED, EXIT_OK
        from hil.testing.flight import fly, with_changes
        from hil.testing.results import error_text, junit_properties

        settings = settings_of(self.config)
        directory = settings.runs_root / run_subdir(self.nodeid)
        try:
            scenario = with_changes(self.source.load(directory), self.changes, "--hil-seed/--hil-controller")
        except HilRunError as exc:
            problems = str(exc)  # reported below, outside the handler: pytest would show both exceptions
        else:
            problems = ""
        if problems:
            pytest.fail(problems, pytrace=False)
        self.run = fly(scenario, self.board, directory, settings)
        self.user_properties.extend(junit_properties(self.run))
        if self.run.exit_code not in (EXIT_OK, EXIT_EXPECT_FAILED):
            pytest.fail(error_text(self.run), pytrace=False)

    def runtest(self) -> None:
        from hil.exit_codes import EXIT_OK
        from hil.testing.results import failure_text

        assert self.run is not None, "setup flies the run"
        if self.run.exit_code != EXIT_OK:
            pytest.fail(failure_text(self.run), pytrace=False)

    def reportinfo(self) -> tuple[Path, int | None, str]:
        return self.path, None, f"{self.name} on {self.board.spec}"


def _suffix(settings: HilSettings, board: Board, controller: str | None) -> str:
    """The item's parameters in its id: the board when several are asked for, the controller when one is."""
    parts = [board.id] if len(settings.boards) > 1 else []
    parts += [controller] if controller else []
    return f"[{'-'.join(parts)}]" if parts else ""


class ScenarioFile(pytest.File):
    def collect(self) -> Iterator[HilItem]:
        settings = settings_of(self.config)
        source = FileSource(self.path)
        seed = {"seed": settings.seed} if settings.seed is not None else {}
        for board in settings.boards:
            for controller in settings.controllers or (None,):
                changes = {**seed, **({"board.controller": controller} if controller else {})}
                yield HilItem.from_parent(self, name=self.path.stem + _suffix(settings, board, controller),
                                          source=source, board=board, changes=changes)


class SweepFile(pytest.File):
    """The sweep's samples, expanded and checked as `hil sweep` does; --hil-seed and --hil-controller leave them as
    the sweep draws or crosses them."""

    def collect(self) -> Iterator[HilItem]:
        from hil.scenario.loader import ScenarioError
        from hil.sweep import SweepError, load_sweep, sample_scenarios
        from hil.sweep.design import samples

        settings = settings_of(self.config)
        try:
            spec = load_sweep(self.path)
            plan = samples(spec)[:settings.limit]
            named, invalid = sample_scenarios(spec, plan)
        except SweepError as exc:
            problems = str(exc)
        except ScenarioError as exc:
            problems = f"{self.path}: its base scenario is not valid:\n{exc}"
        else:
            problems = ""
        if problems:
            yield HilItem.from_parent(self, name=self.path.stem, source=Unusable(problems), board=settings.boards[0],
                                      changes={})
            return
        for sample in plan:
            source: Source = SampleSource(self.path, sample.index, named[sample.index]) if sample.index in named \
                else Unusable(f"{self.path}: sample {sample.index} ({sample.values}) is not a valid scenario: "
                              + "; ".join(reason.reason for reason in invalid[sample.index]))
            for board in settings.boards:
                yield HilItem.from_parent(self, name=f"s{sample.index:05d}" + _suffix(settings, board, None),
                                          source=source, board=board, changes={})


def collect_file(path: Path, parent: pytest.Collector) -> pytest.File | None:
    """The collector for a YAML file the session asked for, or None when the file is not a scenario or a sweep."""
    kind = file_kind(path, named=parent.session.isinitpath(path))
    if kind == "sweep":
        return SweepFile.from_parent(parent, path=path)
    return ScenarioFile.from_parent(parent, path=path) if kind == "scenario" else None
