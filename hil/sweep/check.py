"""Every sample's scenario checked before any worker starts.

A sample made invalid by what it drew (a mass range that reaches the limit) is a result of the sweep, exit
code 2 with its reason. A mistake of the sweep file itself is bad input, refused before anything flies: every
sample invalid (a path to no field, an override the scenario cannot take), or a value written in the file
(a `cross` or `values`/`choice` entry) that makes every sample carrying it invalid (a controller that does not
exist, a string where the field is a number). Each such problem is one line naming the sweep file, the
sweep's key (`cross.board.controller`), the scenario field and what is wrong.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from hil.scenario.loader import Problem, describe
from hil.scenario.schema import Scenario
from hil.sweep.design import PathError, Sample, path_steps, scenario_data
from hil.sweep.spec import SweepSpec

Steps = tuple[str | int, ...]


@dataclass(frozen=True)
class Invalid:
    """One reason a sample's scenario is invalid."""

    key: str  # the sweep's key it lies under ("overrides.duration_s"), "" when none does
    field: str  # the scenario field, as pydantic locates it
    kind: str  # pydantic's error type, or "path" for a path that leads nowhere
    message: str

    @property
    def reason(self) -> str:
        return f"{self.field}: {self.message}"


def _related(steps: Steps, loc: Steps) -> bool:
    """The key's steps and an error's location lie on one branch (either holds the other, in order: pydantic
    adds labels such as a union's branch between the keys)."""
    shorter, longer = (steps, loc) if len(steps) <= len(loc) else (loc, steps)
    remaining = iter(longer)
    return bool(shorter) and shorter[0] == longer[0] and all(step in remaining for step in shorter)


def _keys(spec: SweepSpec) -> list[tuple[str, Steps]]:
    """The sweep's keys, what a sample sets before what the overrides set, the longest first within each."""
    sections = (("vary", spec.vary), ("cross", spec.cross))
    sampled = [(f"{section}.{path}", path_steps(path)) for section, paths in sections for path in paths]
    overridden = [(f"overrides.{path}", path_steps(path)) for path in spec.overrides]
    return [*sorted(sampled, key=lambda k: -len(k[1])), *sorted(overridden, key=lambda k: -len(k[1]))]


def _owner(keys: list[tuple[str, Steps]], loc: Steps) -> str:
    return next((key for key, steps in keys if _related(steps, loc)), "")


def _validate(base: dict[str, Any], spec: SweepSpec, sample: Sample,
              keys: list[tuple[str, Steps]]) -> tuple[dict[str, Any] | None, list[Invalid]]:
    """The sample's scenario data if it is valid, else None and why."""
    try:
        data = scenario_data(base, spec, sample)
    except PathError as exc:
        key = next(k for k, _ in keys if k.split(".", 1)[1] == exc.path)
        return None, [Invalid(key, exc.path, "path", exc.reason)]
    try:
        Scenario.model_validate(data)
    except ValidationError as exc:
        return None, [Invalid(_owner(keys, tuple(e["loc"])), ".".join(map(str, e["loc"])), e["type"], describe(e))
                      for e in exc.errors(include_url=False)]
    return data, []


def validate_samples(base: dict[str, Any], spec: SweepSpec,
                     plan: list[Sample]) -> tuple[dict[int, dict[str, Any]], dict[int, list[Invalid]]]:
    """Each valid sample's scenario data by index, and each invalid sample's reasons by index."""
    keys = _keys(spec)
    valid, invalid = {}, {}
    for sample in plan:
        data, reasons = _validate(base, spec, sample, keys)
        if data is not None:
            valid[sample.index] = data
        else:
            invalid[sample.index] = reasons
    return valid, invalid


def _shared_by_all(invalid: dict[int, list[Invalid]]) -> list[Invalid]:
    """The reasons every sample has (by key, field and kind: the values quoted may differ), or, if they share
    none, the first sample's."""
    first, *others = invalid.values()
    common = [r for r in first if all(any((o.key, o.field, o.kind) == (r.key, r.field, r.kind) for o in reasons)
                                      for reasons in others)]
    return common or first


def _written_values(spec: SweepSpec) -> Iterator[tuple[str, str, list[Any]]]:
    """(sweep key, path, the values written out) of every `cross` entry and listed `vary` dimension."""
    yield from ((f"cross.{path}", path, values) for path, values in spec.cross.items())
    yield from ((f"vary.{path}", path, dim.listed) for path, dim in spec.vary.items() if dim.listed is not None)


def _bad_values(spec: SweepSpec, plan: list[Sample], invalid: dict[int, list[Invalid]]) -> Iterator[tuple[str, str]]:
    """(sweep key, message) for each written value whose every sample is invalid for a reason under that key."""
    for key, path, values in _written_values(spec):
        for value in values:
            carrying = [s.index for s in plan if s.values[path] == value]
            reasons = [next((r for r in invalid.get(i, []) if r.key == key), None) for i in carrying]
            if carrying and all(reasons):
                yield key, f"{value!r} makes every sample with it invalid: {reasons[0].reason}"  # type: ignore[union-attr]


def sweep_problems(spec: SweepSpec, plan: list[Sample], invalid: dict[int, list[Invalid]]) -> list[Problem]:
    """The sweep file's own mistakes found in its samples (nothing when the invalid samples are only results)."""
    if not invalid:
        return []
    if len(invalid) == len(plan):
        found = [(r.key, f"every sample is invalid: {r.reason}") for r in _shared_by_all(invalid)]
    else:
        found = list(dict.fromkeys(_bad_values(spec, plan, invalid)))
    source = spec.source or spec.scenario
    return [Problem(Path(source), spec.line(key), key, message) for key, message in found]
