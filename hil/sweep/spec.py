"""A sweep file: a base scenario, what varies (by the field's path in the scenario), and how it is sampled.

    name: gust_monte_carlo
    scenario: ../scenarios/gust.yaml     # relative to the sweep file
    design: random                       # random: `samples` draws; grid: every combination
    samples: 40
    seed: 2026                           # the sweep's own random stream
    overrides: {payload: [{t_s: 20, mass_kg: 0.0}]}   # applied to the base before anything varies
    vary:
      seed: {integers: [1, 1000000]}
      wind.gusts[0].peak_ned: {polar: {speed: [2, 8], direction_deg: [0, 360]}}
      payload[0].mass_kg: {uniform: [0, 1]}
    cross:                               # every sample is flown with each of these (paired comparison)
      board.controller: [smarc, smpid, backstepping]
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, PrivateAttr, model_validator

Scalar = float | int | str | bool
MAX_SAMPLES = 100_000  # samples of one sweep, crossed values included: days of flights on a cluster
MAX_INTEGER = 2**62  # `integers` draws with numpy's int64, its upper end inclusive
Integer = Annotated[int, Field(ge=-MAX_INTEGER, le=MAX_INTEGER)]


class _SweepPart(BaseModel):
    """A part of the sweep file: an unknown key is an error, NaN and ±inf are refused."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class Range(_SweepPart):
    """Grid: `num` evenly spaced values from start to stop; random: uniform between them."""

    start: float
    stop: float
    num: int = Field(ge=2, le=10_000)


class Normal(_SweepPart):
    mean: float
    sd: float = Field(gt=0)


class Polar(_SweepPart):
    """A horizontal NED vector from a speed and a compass direction (0 = north, 90 = east), each uniform
    in its interval; `down` fixed."""

    speed: tuple[Annotated[float, Field(ge=0)], Annotated[float, Field(ge=0)]]
    direction_deg: tuple[float, float] = (0.0, 360.0)
    down: float = 0.0

    @model_validator(mode="after")
    def _low_to_high(self) -> Polar:
        _check_interval(self.speed, "speed")
        _check_interval(self.direction_deg, "direction_deg")
        return self


def _check_interval(interval: tuple[float, float], name: str) -> None:
    if interval[0] > interval[1]:
        raise ValueError(f"{name} [{interval[0]:g}, {interval[1]:g}] runs high to low; give it as [low, high]")


class Dimension(_SweepPart):
    """Exactly one of: values (a list), range, uniform, normal, integers (inclusive), choice, polar."""

    values: Annotated[list[Any], Field(min_length=1)] | None = None
    range: Range | None = None
    uniform: tuple[float, float] | None = None
    normal: Normal | None = None
    integers: tuple[Integer, Integer] | None = None
    choice: Annotated[list[Any], Field(min_length=1)] | None = None
    polar: Polar | None = None

    @model_validator(mode="before")
    @classmethod
    def _list_is_values(cls, data: Any) -> Any:
        return {"values": data} if isinstance(data, list) else data

    @model_validator(mode="after")
    def _exactly_one(self) -> Dimension:
        given = [k for k in type(self).model_fields if getattr(self, k) is not None]
        if len(given) != 1:
            raise ValueError(f"give exactly one of {', '.join(type(self).model_fields)} (found {given or 'none'})")
        for name in ("uniform", "integers"):
            interval = getattr(self, name)
            if interval is not None:
                _check_interval(interval, name)
        return self

    @property
    def kind(self) -> str:
        return next(k for k in type(self).model_fields if getattr(self, k) is not None)

    @property
    def is_discrete(self) -> bool:
        """A grid can enumerate it."""
        return self.kind in ("values", "range", "choice")

    @property
    def listed(self) -> list[Any] | None:
        """The values written out in the sweep file (a list or a choice), or None for a range or distribution."""
        return self.values if self.values is not None else self.choice

    @property
    def count(self) -> int:
        """How many values a grid enumerates."""
        return self.range.num if self.range is not None else len(self.listed or [])


PathKey = Annotated[str, Field(pattern=r"^[A-Za-z_][A-Za-z0-9_]*(\[\d+\])*(\.[A-Za-z_][A-Za-z0-9_]*(\[\d+\])*)*$")]


class SweepSpec(_SweepPart):
    name: str = Field(pattern=r"^[A-Za-z0-9_.-]+$")
    description: str = ""
    scenario: Path
    design: Literal["grid", "random"] = "random"
    samples: int = Field(1, ge=1, le=100_000, description="random design: the number of draws")
    seed: int = Field(0, ge=0)
    overrides: dict[PathKey, Any] = Field(default_factory=dict)
    vary: dict[PathKey, Dimension] = Field(default_factory=dict)
    cross: dict[PathKey, Annotated[list[Any], Field(min_length=1)]] = Field(default_factory=dict)
    _source: Path | None = PrivateAttr(None)  # the sweep file, when it came from one
    _lines: dict[str, int] = PrivateAttr(default_factory=dict)  # "vary.seed" -> its line in the sweep file

    @model_validator(mode="after")
    def _grid_is_enumerable(self) -> SweepSpec:
        if self.design == "grid":
            sampled = [path for path, dim in self.vary.items() if not dim.is_discrete]
            if sampled:
                raise ValueError(f"a grid design enumerates lists and ranges only; {', '.join(sampled)} "
                                 "is a distribution (use design: random)")
        overlap = set(self.vary) & set(self.cross)
        if overlap:
            raise ValueError(f"{', '.join(sorted(overlap))} both varied and crossed")
        if self.total > MAX_SAMPLES:
            raise ValueError(f"{self.total:,} samples; a sweep has at most {MAX_SAMPLES:,} (split it, or sample "
                             "it with design: random)")
        return self

    def from_file(self, source: Path, lines: dict[str, int]) -> SweepSpec:
        """This spec, remembering its file and the line of each key ("vary.seed") for the messages."""
        located = self.model_copy()
        located._source, located._lines = source, lines
        return located

    @property
    def source(self) -> Path | None:
        return self._source

    def line(self, key: str) -> int | None:
        return self._lines.get(key)

    @property
    def total(self) -> int:
        """The number of samples, crossed values included."""
        draws = math.prod(d.count for d in self.vary.values()) if self.design == "grid" else self.samples
        return draws * math.prod(len(values) for values in self.cross.values())
