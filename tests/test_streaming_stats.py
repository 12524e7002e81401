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


def test_reads_between_blocks_change_nothing():
    """Values are held and folded in blocks: a read mid-block folds what is held, and a series read often ends
    where one read once ends (counts, bins, extremes, sums)."""
    rng = np.random.default_rng(3)
    vectors, durations = rng.normal(size=(1000, 2)), rng.lognormal(np.log(2e-4), 0.5, size=1000)
    read_often, read_once = Extremes(2), Extremes(2)
    hist_often, hist_once = LogHistogram(), LogHistogram()
    for k, (row, d) in enumerate(zip(vectors, durations, strict=True)):
        for acc, hist in ((read_often, hist_often), (read_once, hist_once)):
            acc.add(row)
            hist.add(float(d))
        if k % 37 == 0:
            assert read_often.n == hist_often.n == k + 1
            assert read_often.stats(("a", "b"))["a"]["max"] == vectors[:k + 1, 0].max()
            assert hist_often.max == durations[:k + 1].max()
    often, once = read_often.stats(("a", "b")), read_once.stats(("a", "b"))
    for axis in ("a", "b"):
        assert often[axis] == pytest.approx(once[axis], rel=1e-12)
    hist_often.summary()
    hist_once.summary()
    assert np.array_equal(hist_often.bins, hist_once.bins) and hist_often.n == hist_once.n == 1000
