"""Statistics kept in constant memory, so that a run of hours costs no more memory than one of seconds.

`Extremes` is exact (min, max, RMS, max |x| per axis). `LogHistogram` gives percentiles of positive
durations to within its bin width (1 % of the value) and the exact maximum.
"""

from __future__ import annotations

import math

import numpy as np


class Extremes:
    """min, max, RMS and max |x| of a stream of vectors, per component."""

    def __init__(self, size: int) -> None:
        self.n = 0
        self.low = np.full(size, np.inf)
        self.high = np.full(size, -np.inf)
        self.sum_sq = np.zeros(size)

    def add(self, x: np.ndarray) -> None:
        self.n += 1
        np.minimum(self.low, x, out=self.low)
        np.maximum(self.high, x, out=self.high)
        self.sum_sq += x * x

    def stats(self, names: tuple[str, ...], scale: float = 1.0) -> dict[str, dict[str, float]]:
        """Per component: {min, max, rms, max_abs}, times `scale` (e.g. rad → deg); {} if empty."""
        if self.n == 0:
            return {}
        rms = np.sqrt(self.sum_sq / self.n)
        return {name: {"min": float(self.low[i] * scale), "max": float(self.high[i] * scale),
                       "rms": float(rms[i] * scale),
                       "max_abs": float(max(abs(self.low[i]), abs(self.high[i])) * scale)}
                for i, name in enumerate(names)}


class LogHistogram:
    """Counts of positive values in bins 1 % wide from `floor` up; percentiles read off the bins."""

    GROWTH = 1.01

    def __init__(self, floor: float = 1e-7, ceiling: float = 100.0) -> None:
        self.floor = floor
        self.bins = np.zeros(int(math.log(ceiling / floor) / math.log(self.GROWTH)) + 2, dtype=np.int64)
        self.n = 0
        self.max = 0.0

    def add(self, value: float) -> None:
        self.n += 1
        self.max = max(self.max, value)
        index = 0 if value <= self.floor else int(math.log(value / self.floor) / math.log(self.GROWTH)) + 1
        self.bins[min(index, len(self.bins) - 1)] += 1

    def percentile(self, q: float) -> float:
        """The value below which q % of the samples lie (the upper edge of its bin, capped at the max)."""
        rank = math.ceil(q / 100 * self.n)
        index = int(np.searchsorted(np.cumsum(self.bins), max(rank, 1)))
        return min(self.floor * self.GROWTH ** index, self.max)

    def summary(self, scale: float = 1.0) -> dict[str, float]:
        """{p50, p99, max} times `scale`; {} if empty."""
        if self.n == 0:
            return {}
        return {"p50": self.percentile(50) * scale, "p99": self.percentile(99) * scale, "max": self.max * scale}
