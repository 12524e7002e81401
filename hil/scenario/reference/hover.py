"""`reference: {type: hover}`: hold one point at one yaw."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from pydantic import ConfigDict

from hil.scenario.fields import Distance, Length
from hil.scenario.reference.base import ReferenceModel, RefSample, wrap_yaw


class HoverRef(ReferenceModel):
    model_config = ConfigDict(json_schema_extra={"examples": [
        {"type": "hover", "altitude_m": 12.0, "yaw_deg": 90.0},
        {"type": "hover", "altitude_m": 4.0, "north_m": 3.0, "east_m": -4.0, "yaw_deg": -135.0}]})

    type: Literal["hover"]
    altitude_m: Length = 10.0
    north_m: Distance = 0.0
    east_m: Distance = 0.0
    yaw_deg: float = 0.0

    def trajectory(self) -> Hover:
        return Hover((self.north_m, self.east_m, -self.altitude_m), wrap_yaw(math.radians(self.yaw_deg)))


@dataclass(frozen=True)
class Hover:
    point_ned: tuple[float, float, float]
    yaw: float = 0.0
    _sample: RefSample = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        # the same sample at every step (the bench waits for it), built once; its readers only read it (writable
        # all the same: the compiled packers of a setpoint take writable arrays only)
        object.__setattr__(self, "_sample", RefSample(np.array(self.point_ned, float), np.zeros(3), np.zeros(3),
                                                      self.yaw))

    def sample(self, t: float) -> RefSample:
        return self._sample
