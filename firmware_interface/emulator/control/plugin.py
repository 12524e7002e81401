"""What a controller module hands the registry (`control/registry.py`): its class, its gains model, and
how a ground station sees the gains. The schema, the CLI, the emulator's config and its parameters all
read the registry, so a controller is one module plus one line there."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol

from pydantic import BaseModel, ConfigDict

from firmware_interface.emulator.control.base import Controller, Nominal


class ControllerGains(BaseModel):
    """Base of every controller's gains: frozen (PARAM_SET swaps the model), no unknown keys, no NaN."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class ControllerClass(Protocol):
    """A controller class: built from the nominal vehicle and its gains."""

    @property
    def name(self) -> str: ...

    @property
    def internal_keys(self) -> tuple[str, ...]: ...

    def __call__(self, nominal: Nominal, gains: Any) -> Controller: ...


@dataclass(frozen=True)
class ControllerPlugin:
    controller: ControllerClass
    gains: type[ControllerGains]
    param_prefix: str  # its PARAM names are PREFIX_GAIN, cut to MAVLink's 16 characters
    runtime_gains: tuple[str, ...]  # the gains `update` reads each step: a PARAM_SET in flight takes effect

    @property
    def name(self) -> str:
        return self.controller.name

    def build(self, nominal: Nominal, gains: ControllerGains) -> Controller:
        return self.controller(nominal, gains)
