"""Sensor faults between two times: dropout, stuck output, bias step, extra noise."""

from __future__ import annotations

from typing import Literal, TypeVar, cast

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

FaultKind = Literal["dropout", "stuck", "bias", "noise"]
SensorName = Literal["accel", "gyro", "mag", "baro", "gps"]
Sample = TypeVar("Sample", bound=tuple[float, ...])  # a sensor's output, kept at its own length


class SensorFault(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    sensor: SensorName
    kind: FaultKind
    start_s: float = Field(ge=0)
    end_s: float = Field(gt=0)
    magnitude: float = Field(0.0, description="bias step or extra noise σ, in the sensor's SI unit")

    def active(self, t_s: float) -> bool:
        return self.start_s <= t_s < self.end_s


class FaultInjector:
    """Applies the faults of one sensor to its output; None means the sample is dropped."""

    def __init__(self, faults: list[SensorFault], rng: np.random.Generator) -> None:
        self.faults = faults
        self._rng = rng
        self._last: tuple[float, ...] | None = None

    def apply(self, t_s: float, value: Sample) -> Sample | None:
        out: tuple[float, ...] = value
        for fault in self.faults:
            if not fault.active(t_s):
                continue
            if fault.kind == "dropout":
                return None
            if fault.kind == "stuck" and self._last is not None:
                return cast(Sample, self._last)
            if fault.kind == "bias":
                out = tuple(v + fault.magnitude for v in out)
            elif fault.kind == "noise":
                noise = self._rng.standard_normal(len(out))
                out = tuple(v + fault.magnitude * n for v, n in zip(out, noise, strict=True))
        self._last = out
        return cast(Sample, out)
