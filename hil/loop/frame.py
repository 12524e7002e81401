"""One bench step, as the sinks (recorder, telemetry, metrics) receive it. SI units, NED/FRD."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from firmware_interface.hil_codec import GpsFix, SensorReadings
from hil.scenario.environment import EnvironmentSample
from hil.scenario.reference import RefSample
from plant_fmu.state import PlantState


@dataclass(slots=True)
class StepFrame:
    t_us: int  # bench (simulation) time
    mission_t: float  # s; negative before the reference starts
    phase: str
    truth: PlantState  # the plant after this step
    reference: RefSample | None
    readings: SensorReadings
    gps: GpsFix | None
    motors: tuple[float, ...]
    armed: bool
    environment: EnvironmentSample
    board: list[tuple[str, dict[str, Any]]] = field(default_factory=list)  # board messages of this step
    board_offset_ned: np.ndarray | None = None  # the board's local frame - the truth, once aligned (at arming)
    step_wall_s: float = 0.0
    started_s: float = 0.0  # the step's start on the machine's monotonic clock (perf_counter: CLOCK_MONOTONIC)
    round_trip_s: float | None = None
    messages: list[tuple[str, dict[str, Any]]] | None = None  # the channel payloads, built once (recorder)
    sent: list[tuple[str, dict[str, Any]]] = field(default_factory=list)  # battery, sticks sent (hil.loop.senders)
