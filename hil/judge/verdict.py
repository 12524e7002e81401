"""A behaviour expectation's verdict, and the moment of a flight it names (bench time and mission clock)."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any


@dataclass(frozen=True)
class Verdict:
    expectation: str  # its name in `expect:`
    met: bool
    found: str  # what the flight did, as a reader wants it
    bound: str
    decided_t_us: int  # the bench time at which it was decided
    decided_mission_t: float | None  # the same on the mission clock (None before the mission clock ran)

    def line(self) -> str:
        when = (f"mission time {self.decided_mission_t:.2f} s" if self.decided_mission_t is not None
                else f"bench time {self.decided_t_us * 1e-6:.2f} s")
        return f"{self.expectation}: {self.found} (expected {self.bound}), decided at {when}"

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass
class Moment:
    t_us: int
    mission_t: float

    @property
    def clock(self) -> float | None:
        return self.mission_t if math.isfinite(self.mission_t) else None
