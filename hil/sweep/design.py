"""The samples of a sweep: each one a set of (path → value), and the scenario it makes."""

from __future__ import annotations

import copy
import itertools
import math
import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from hil.sweep.spec import Dimension, SweepSpec

_STEP = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)((?:\[\d+\])*)")


@dataclass(frozen=True)
class Sample:
    index: int
    values: dict[str, Any]  # path -> value, varied and crossed


class PathError(KeyError):
    """A path that leads nowhere in the scenario: a list item past the end, a key inside a value."""

    def __init__(self, path: str, reason: str) -> None:
        super().__init__(path, reason)
        self.path, self.reason = path, reason

    def __str__(self) -> str:
        return f"{self.path}: {self.reason}"


def path_steps(path: str) -> tuple[str | int, ...]:
    """`a.b[0].c` as ("a", "b", 0, "c")."""
    steps: list[str | int] = []
    for part in path.split("."):
        name, indexes = _STEP.fullmatch(part).groups()  # type: ignore[union-attr]
        steps.append(name)
        steps += [int(i) for i in re.findall(r"\d+", indexes)]
    return tuple(steps)


def _item(node: Any, path: str, index: int) -> Any:
    if not isinstance(node, list):
        raise PathError(path, f"[{index}] indexes a {type(node).__name__}, not a list")
    if index >= len(node):
        raise PathError(path, f"no item [{index}]: the scenario has {len(node)} there")
    return node[index]


def set_path(tree: dict[str, Any], path: str, value: Any) -> None:
    """Set `a.b[0].c` in a scenario's plain data; a missing mapping on the way is created, a missing list
    item is an error (PathError, a KeyError naming the path)."""
    node: Any = tree
    steps = path_steps(path)
    for key, following in itertools.pairwise(steps):
        if isinstance(key, int):
            node = _item(node, path, key)
        elif isinstance(node, dict):
            node = node.setdefault(key, [] if isinstance(following, int) else {})
        else:
            raise PathError(path, f"{key!r} is not inside a mapping")
    last = steps[-1]
    if isinstance(last, int):
        _item(node, path, last)
        node[last] = value
    elif isinstance(node, dict):
        node[last] = value
    else:
        raise PathError(path, f"{last!r} is not inside a mapping")


def scenario_data(base: dict[str, Any], spec: SweepSpec, sample: Sample) -> dict[str, Any]:
    """The base scenario with the sweep's overrides and then the sample's values applied."""
    data = copy.deepcopy(base)
    for path, value in {**spec.overrides, **sample.values}.items():
        set_path(data, path, copy.deepcopy(value))  # a sample setting inside an override must not change the spec
    return data


def _grid_values(dim: Dimension) -> list[Any]:
    if dim.range is not None:
        return [float(v) for v in np.linspace(dim.range.start, dim.range.stop, dim.range.num)]
    return list(dim.values if dim.values is not None else dim.choice or [])


def _draw(dim: Dimension, rng: np.random.Generator) -> Any:
    options = dim.values if dim.values is not None else dim.choice
    if options is not None:
        return options[int(rng.integers(len(options)))]
    if dim.range is not None:
        return float(rng.uniform(dim.range.start, dim.range.stop))
    if dim.uniform is not None:
        return float(rng.uniform(*dim.uniform))
    if dim.normal is not None:
        return float(rng.normal(dim.normal.mean, dim.normal.sd))
    if dim.integers is not None:
        return int(rng.integers(dim.integers[0], dim.integers[1] + 1))
    assert dim.polar is not None
    speed = float(rng.uniform(*dim.polar.speed))
    heading = math.radians(float(rng.uniform(*dim.polar.direction_deg)))
    return [speed * math.cos(heading), speed * math.sin(heading), dim.polar.down]


def samples(spec: SweepSpec) -> list[Sample]:
    """Every sample in order: each draw (random) or combination (grid) of `vary`, crossed with `cross`
    innermost, so that the crossed runs of one draw are neighbours."""
    if spec.design == "grid":
        paths = list(spec.vary)
        draws = [dict(zip(paths, combo, strict=True))
                 for combo in itertools.product(*(_grid_values(spec.vary[p]) for p in paths))]
    else:
        rng = np.random.default_rng(spec.seed)
        draws = [{path: _draw(dim, rng) for path, dim in spec.vary.items()} for _ in range(spec.samples)]
    crossed = [dict(zip(spec.cross, combo, strict=True)) for combo in itertools.product(*spec.cross.values())]
    return [Sample(i, {**draw, **cross})
            for i, (draw, cross) in enumerate(itertools.product(draws, crossed))]
