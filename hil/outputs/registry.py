"""The run's outputs, opened in this order before any board starts and closed with the run's outcome: each entry
opens its sink from the run's context, or returns None when the run did not ask for it. Adding an output is its
module (a `Sink` and an `open_output`) plus one line here."""

from __future__ import annotations

from collections.abc import Callable

from hil.loop.sink import Sink
from hil.outputs import foxglove_live, recorder, telemetry
from hil.outputs.context import OutputContext

OUTPUTS: tuple[Callable[[OutputContext], Sink | None], ...] = (
    recorder.open_output,  # the run directory and recording.mcap: first, always
    foxglove_live.open_output,  # --foxglove: the live Foxglove view
    telemetry.open_output,  # Zenoh, unless --no-telemetry
)
