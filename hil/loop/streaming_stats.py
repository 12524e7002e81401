"""Statistics kept in constant memory, so that a run of hours costs no more memory than one of seconds.

`Extremes` is exact (min, max, RMS, max |x| per axis). `LogHistogram` gives percentiles of positive
durations to within its bin width (1 % of the value) and the exact maximum.

Both take a step's value into a block and fold a whole block in at once (`BLOCK` values: one numpy call each for
what cost four, ~3 µs, at every step; issue 36). Whatever reads them folds the values held first.
"""

from __future__ import annotations

import math

import numpy as np

BLOCK = 64  # values a statistic holds before it folds them in


class Extremes:
    """min, max, RMS and max |x| of a stream of vectors, per component."""

    def __init__(self, size: int) -> None:
        self._folded = 0
        self.low = np.full(size, np.inf)
        self.high = np.full(size, -np.inf)
        self.sum_sq = np.zeros(size)
        self._block = np.empty((BLOCK, size))  # values not folded in yet: rows 0.._held
        self._held = 0

    @property
    def n(self) -> int:
        return self._folded + self._held

    def add(self, x: np.ndarray) -> None:
        self._block[self._held] = x
        self._held += 1
        if self._held == BLOCK:
            self._fold()

    def _fold(self) -> None:
        rows = self._block[:self._held]
        if len(rows):
            np.minimum(self.low, rows.min(axis=0), out=self.low)
            np.maximum(self.high, rows.max(axis=0), out=self.high)
            self.sum_sq += (rows * rows).sum(axis=0)
        self._folded += self._held
        self._held = 0

    def stats(self, names: tuple[str, ...], scale: float = 1.0) -> dict[str, dict[str, float]]:
        """Per component: {min, max, rms, max_abs}, times `scale` (e.g. rad → deg); {} if empty."""
        self._fold()
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
        self._folded = 0
        self._max = 0.0
        self._held: list[float] = []  # values not counted yet

    @property
    def n(self) -> int:
        return self._folded + len(self._held)

    @property
    def max(self) -> float:
        self._fold()
        return self._max

    def add(self, value: float) -> None:
        held = self._held
        held.append(value)
        if len(held) == BLOCK:
            self._fold()

    def _fold(self) -> None:
        """The held values into their bins: bin 0 at or below `floor`, then k for floor·GROWTH^(k-1) < v."""
        if not self._held:
            return
        values = np.array(self._held)
        self._held = []
        self._folded += len(values)
        self._max = max(self._max, float(values.max()))
        above = values > self.floor
        index = np.zeros(len(values), dtype=np.int64)
        index[above] = (np.log(values[above] / self.floor) / math.log(self.GROWTH)).astype(np.int64) + 1
        np.add.at(self.bins, np.minimum(index, len(self.bins) - 1), 1)

    def percentile(self, q: float) -> float:
        """The value below which q % of the samples lie (the upper edge of its bin, capped at the max)."""
        self._fold()
        rank = math.ceil(q / 100 * self.n)
        index = int(np.searchsorted(np.cumsum(self.bins), max(rank, 1)))
        return min(self.floor * self.GROWTH ** index, self.max)

    def summary(self, scale: float = 1.0) -> dict[str, float]:
        """{p50, p99, max} times `scale`; {} if empty."""
        self._fold()
        if self.n == 0:
            return {}
        return {"p50": self.percentile(50) * scale, "p99": self.percentile(99) * scale, "max": self.max * scale}
