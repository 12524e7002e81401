"""The scenario schema's shared vocabulary: the bench's limits, the bounded field types, the base model.

Bounds that keep a run possible and finite live on the types: a mission of at most MAX_DURATION_S, positions
within MAX_DISTANCE_M of home (take-off flies there at 1.5 m/s), speeds up to MAX_SPEED_M_S, at most
MAX_MASS_KG. `hil.scenario.schema` and the reference types (`hil.scenario.reference`) both build on it.
"""

from __future__ import annotations

import math
from typing import Annotated, TypeAlias

from pydantic import BaseModel, BeforeValidator, ConfigDict, Discriminator, Field, Tag

from hil.sensors.geodesy import MAX_DISTANCE_M

MAX_DURATION_S = 86_400.0  # 24 h of simulated time: longer would never finish in practice
MAX_MASS_KG = 1_000.0
MAX_SPEED_M_S = 100.0  # reference speeds and wind components

SCENARIO_DIR = "scenario_dir"  # the validation context's key: the scenario file's folder, where relative paths start
Duration = Annotated[float, Field(gt=0, le=MAX_DURATION_S)]
MissionTime = Annotated[float, Field(ge=0, le=MAX_DURATION_S)]
UntilEnd = Annotated[float, Field(gt=0, allow_inf_nan=True, description="s, or .inf (null in JSON): until the end"),
                     BeforeValidator(lambda value: math.inf if value is None else value)]  # orjson writes inf as null
Distance = Annotated[float, Field(ge=-MAX_DISTANCE_M, le=MAX_DISTANCE_M)]
Length = Annotated[float, Field(gt=0, le=MAX_DISTANCE_M)]
Speed = Annotated[float, Field(gt=0, le=MAX_SPEED_M_S)]
WindSpeed = Annotated[float, Field(ge=-MAX_SPEED_M_S, le=MAX_SPEED_M_S)]
Mass = Annotated[float, Field(ge=0, le=MAX_MASS_KG)]
PositiveFloat = Annotated[float, Field(gt=0)]
Position = tuple[Distance, Distance, Distance]
WindVector = tuple[WindSpeed, WindSpeed, WindSpeed]


class ScenarioModel(BaseModel):
    """A part of the scenario file: an unknown key is an error, NaN and ±inf are refused."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


def number_unless(when: tuple[type, ...]) -> Discriminator:
    """Picks the "other" branch of a number-or-other union by the value's Python type (one of `when`), so
    that a mistake is reported once, by the branch the value was meant for, rather than once by each."""
    return Discriminator(lambda value: "other" if isinstance(value, when) else "number")


ExpressionOrNumber: TypeAlias = Annotated[Annotated[float, Tag("number")] | Annotated[str, Tag("other")],
                                          number_unless((str,))]
