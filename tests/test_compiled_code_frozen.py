"""A frozen group's functions (firmware_interface/compiled_code.py): called directly through their one signature's
machine code, with the dispatcher's type check kept on the first call after the freeze and one call in CHECK_EVERY.
The results are checked against the same functions run as plain Python."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from firmware_interface.compiled_code import CHECK_EVERY, CompiledCode


def weighted_into(values: np.ndarray, weight: float, offset: int, out: np.ndarray) -> float:
    """out = weight * values + offset; returns the sum of out (a step's shape: arrays in and out, and numbers)."""
    total = 0.0
    for i in range(values.size):
        out[i] = weight * values[i] + offset
        total += out[i]
    return total


@pytest.fixture
def group(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> CompiledCode:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    source = tmp_path / "weighted.py"
    source.write_text("# the group's source, for its cache directory's name\n")
    return CompiledCode("frozen-test", (source,))


def test_a_frozen_function_called_directly_gives_what_its_python_gives(group: CompiledCode) -> None:
    entry = group.compiled(weighted_into)
    out = np.zeros(5)
    entry(np.ones(5), 1.0, 0, out)
    group.freeze()
    assert entry.direct is not None  # one signature: called through it
    rng = np.random.default_rng(7)
    for k in range(3 * CHECK_EVERY):  # direct calls and checked ones alike
        values, weight = rng.normal(size=5), float(rng.normal())
        expected_out = np.zeros(5)
        expected = weighted_into(values, weight, k, expected_out)
        assert entry(values, weight, k, out) == pytest.approx(expected, rel=1e-12, abs=1e-12)
        np.testing.assert_allclose(out, expected_out, rtol=1e-12, atol=1e-12)


def test_a_frozen_function_refuses_a_type_it_was_not_compiled_for_at_once_and_within_check_every_calls(
        group: CompiledCode) -> None:
    entry = group.compiled(weighted_into)
    floats, out = np.ones(5), np.zeros(5)
    entry(floats, 1.0, 0, out)
    group.freeze()
    integers = np.ones(5, dtype=np.int64)  # the same size in bytes: read directly, it would be wrong, not unsafe
    with pytest.raises(TypeError):  # the first call after the freeze is checked
        entry(integers, 1.0, 0, out)
    entry(floats, 1.0, 0, out)  # checked, and opens a run of direct calls
    refused_after = None
    for call in range(1, CHECK_EVERY + 1):
        try:
            entry(integers, 1.0, 0, out)
        except TypeError:
            refused_after = call
            break
    assert refused_after == CHECK_EVERY  # the direct run, then the check


def test_a_function_compiled_for_two_signatures_stays_on_the_dispatcher(group: CompiledCode) -> None:
    entry = group.compiled(weighted_into)
    out = np.zeros(3)
    assert entry(np.ones(3), 2.0, 1, out) == pytest.approx(9.0)
    assert entry(np.ones(3, dtype=np.int64), 2.0, 1, out) == pytest.approx(9.0)
    group.freeze()
    assert entry.direct is None
    for _ in range(CHECK_EVERY + 1):  # every call dispatched on its types, each to its own machine code
        assert entry(np.full(3, 2.0), 2.0, 1, out) == pytest.approx(15.0)
        assert entry(np.full(3, 2, dtype=np.int64), 2.0, 1, out) == pytest.approx(15.0)
    with pytest.raises(TypeError):
        entry(np.ones(3, dtype=np.float32), 2.0, 1, out)
