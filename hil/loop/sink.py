"""The sinks' contract: every step's frame and every run event, in order, then the run's outcome once at the
end. The outputs (recording, Zenoh, the live Foxglove view) are sinks; they are in hil/outputs/."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

from hil.loop.frame import StepFrame


@dataclass(frozen=True)
class Outcome:
    """How the run ended, as the sinks close with it."""

    t_us: int  # the bench's time at the end
    metrics: dict[str, Any]  # metrics.json: exit code, reason, failed expectations and every metric
    summary: str  # the printed summary


class Sink(Protocol):
    def on_step(self, frame: StepFrame) -> None:
        """One step, after the board's reply (its messages decoded in `frame.board`)."""

    def on_event(self, t_us: int, text: str) -> None:
        """A run event: a phase change, a board text, a failsafe."""

    def close(self, outcome: Outcome) -> None:
        """The run is over; called once whatever ended it, also after a failed open of another sink."""


class FrameSink:
    """A sink that takes only the frames: a user's or a test's callback."""

    def __init__(self, on_step: Callable[[StepFrame], None]) -> None:
        self.on_step = on_step

    def on_event(self, t_us: int, text: str) -> None:
        """Not wanted."""

    def close(self, outcome: Outcome) -> None:
        """Nothing to close."""
