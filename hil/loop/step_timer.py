"""Where a bench step's wall time goes, per part (the `timing.breakdown_us_per_step` of metrics.json)."""

from __future__ import annotations

import time


class StepTimer:
    """`lap(part)` charges the wall time since the previous lap (or `start`) to `part`."""

    def __init__(self, totals_s: dict[str, float]) -> None:
        self.totals_s = totals_s
        self.started = self._last = 0.0
        self.longest: tuple[str, float] = ("", 0.0)  # this step's longest part and its seconds: why a step ran late

    def start(self) -> float:
        self.started = self._last = time.perf_counter()
        self.longest = ("", 0.0)
        return self.started

    def lap(self, part: str) -> float:
        now = time.perf_counter()
        elapsed = now - self._last
        self.totals_s[part] += elapsed
        if elapsed > self.longest[1]:
            self.longest = (part, elapsed)
        self._last = now
        return now
