"""The run's streaming statistics against numpy on the whole series (the independent reference)."""

from __future__ import annotations

import numpy as np
import pytest

from hil.loop.streaming_stats import Extremes, LogHistogram


def test_extremes_equal_numpy_on_the_whole_series():
    rng = np.random.default_rng(1)
    series = rng.normal(0.2, 1.5, size=(5000, 3))
    acc = Extremes(3)
    for row in series:
        acc.add(row)
    stats = acc.stats(("x", "y", "z"), scale=2.0)
    for i, axis in enumerate("xyz"):
        column = series[:, i] * 2.0
        assert stats[axis]["min"] == pytest.approx(column.min(), rel=1e-12)
        assert stats[axis]["max"] == pytest.approx(column.max(), rel=1e-12)
        assert stats[axis]["rms"] == pytest.approx(np.sqrt(np.mean(column**2)), rel=1e-10)
        assert stats[axis]["max_abs"] == pytest.approx(np.abs(column).max(), rel=1e-12)
    assert Extremes(3).stats(("x", "y", "z")) == {}


@pytest.mark.parametrize("q", [50, 90, 99])
def test_log_histogram_percentiles_are_within_one_percent(q):
    rng = np.random.default_rng(2)
    durations = rng.lognormal(np.log(300e-6), 0.6, size=20_000)  # step times around 300 µs
    hist = LogHistogram()
    for d in durations:
        hist.add(float(d))
    exact = np.percentile(durations, q, method="inverted_cdf")
    assert hist.percentile(q) == pytest.approx(exact, rel=0.011)
    assert hist.max == durations.max() and hist.n == len(durations)


def test_log_histogram_memory_does_not_grow():
    hist = LogHistogram()
    size = hist.bins.nbytes
    for i in range(100_000):
        hist.add(1e-4 * (1 + i % 7))
    assert hist.bins.nbytes == size and hist.summary(1e6)["max"] == pytest.approx(700.0)
