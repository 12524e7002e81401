"""What an output is opened with: the run it records or publishes, and the options that ask for it."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from firmware_interface.geodesy import LocalFrame
from hil.outputs.disk import DiskWatch
from hil.outputs.foxglove_messages import mission_scene
from hil.outputs.zenoh_session import ZenohOptions
from hil.scenario.schema import Scenario


class OutputError(Exception):
    """An output the run was asked for cannot open (a taken address, a bad Zenoh configuration): bad input,
    said in one line, before any board starts."""


@dataclass(frozen=True)
class OutputContext:
    run_dir: Path
    scenario: Scenario
    meta: dict[str, Any]  # meta.json: scenario name, seed, rate, board, pacing
    start_ns: int  # the run's wall-clock start: log times are this plus the bench's time
    paced: bool  # the run is paced on the wall clock: an output must never hold a step up
    rates_hz: dict[str, float]  # live channels' rates (the scenario's telemetry.rates_hz and the command line's)
    link_counters: Callable[[], dict[str, int]]  # the board link's frame counters, once a board is attached
    disk: DiskWatch  # the run directory's space: its reserve, the first write that failed for lack of it
    telemetry: ZenohOptions | None = None  # publish on Zenoh with these options; None: not
    foxglove: str | None = None  # serve a live Foxglove view on this HOST:PORT; None: not

    @property
    def local_frame(self) -> LocalFrame:
        return self.scenario.home.frame

    @property
    def resolved_scenario(self) -> dict[str, Any]:
        return self.scenario.model_dump(mode="json")

    @property
    def scene(self) -> Any:
        """The Foxglove scene of the mission (the power line, the path), for views that draw it."""
        return mission_scene(self.scenario, self.start_ns)
