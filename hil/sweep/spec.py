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

from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

Scalar = float | int | str | bool


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class Range(_Model):
    """Grid: `num` evenly spaced values from start to stop; random: uniform between them."""

    start: float
    stop: float
    num: int = Field(ge=2, le=10_000)


class Normal(_Model):
    mean: float
    sd: float = Field(gt=0)


class Polar(_Model):
    """A horizontal NED vector from a speed and a compass direction (0 = north, 90 = east), each uniform
    in its interval; `down` fixed."""

    speed: tuple[float, float]
    direction_deg: tuple[float, float] = (0.0, 360.0)
    down: float = 0.0


class Dimension(_Model):
    """Exactly one of: values (a list), range, uniform, normal, integers (inclusive), choice, polar."""

    values: list[Any] | None = None
    range: Range | None = None
    uniform: tuple[float, float] | None = None
    normal: Normal | None = None
    integers: tuple[int, int] | None = None
    choice: list[Any] | None = None
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
        return self

    @property
    def kind(self) -> str:
        return next(k for k in type(self).model_fields if getattr(self, k) is not None)

    @property
    def is_discrete(self) -> bool:
        """A grid can enumerate it."""
        return self.kind in ("values", "range", "choice")


PathKey = Annotated[str, Field(pattern=r"^[A-Za-z_][A-Za-z0-9_]*(\[\d+\])*(\.[A-Za-z_][A-Za-z0-9_]*(\[\d+\])*)*$")]


class SweepSpec(_Model):
    name: str = Field(pattern=r"^[A-Za-z0-9_.-]+$")
    description: str = ""
    scenario: Path
    design: Literal["grid", "random"] = "random"
    samples: int = Field(1, ge=1, le=100_000, description="random design: the number of draws")
    seed: int = Field(0, ge=0)
    overrides: dict[PathKey, Any] = Field(default_factory=dict)
    vary: dict[PathKey, Dimension] = Field(default_factory=dict)
    cross: dict[PathKey, list[Any]] = Field(default_factory=dict)

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
        return self
