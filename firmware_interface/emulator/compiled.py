"""The flight code's hot path, compiled to machine code by numba.

Why: the emulator's estimator, control laws and mixer are a few hundred operations on 3- and 4-vectors per
step; numpy spends ~1 µs on each, so a step cost ~100 µs of interpreter work. numba compiles the same Python
source (the paper's equations stay as written) into native code: one definition of each law, no C twin.

- `flight_code`: a step the emulator calls from Python (an estimator update, a control law, the mixer).
- `shared_maths`: a formula both sides use (quaternions, Euler rates, C(η, η̇)): plain Python when the
  bench calls it, compiled into the flight code that calls it.

Compiled code is cached on disk, so the compile cost (seconds) is paid once, by the first process that flies
a law; later processes load it. numba keys its cache on the calling function's file only, so a changed helper
in another file would leave stale machine code: the cache directory is named after a digest of every source
of the flight code and numba's version instead, and any change compiles afresh.

Rules for compiled code: numbers and float64 arrays in and out, no Python objects; matrix products spelled
out (`geometry.mat_vec`, `geometry.dot`), since numba's `@` needs a BLAS it does not ship.
"""

from __future__ import annotations

import functools
import hashlib
import os
from collections.abc import Callable
from importlib.metadata import version
from pathlib import Path
from types import ModuleType
from typing import Any, TypeVar, cast

F = TypeVar("F", bound=Callable[..., Any])
FLIGHT_CODE = Path(__file__).resolve().parent  # the emulator package: every source a compiled law can reach
_SHARED: list[Callable[..., Any]] = []  # `shared_maths` functions, made known to numba before the first compile


def cache_dir() -> Path:
    """Where the compiled flight code of these exact sources lives (XDG cache, ~/.cache by default)."""
    digest = hashlib.sha256(version("numba").encode())
    for source in sorted(FLIGHT_CODE.rglob("*.py")):
        digest.update(source.relative_to(FLIGHT_CODE).as_posix().encode())
        digest.update(source.read_bytes())
    root = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return root / "hil-bench" / f"flight-code-{digest.hexdigest()[:16]}"


@functools.cache
def _numba() -> ModuleType:
    """numba, imported and set up at the first compiled call: the `hil` commands that fly nothing never load
    it (~0.2 s of start-up)."""
    import numba
    from numba.extending import register_jitable

    numba.config.CACHE_DIR = str(cache_dir())  # type: ignore[attr-defined]  # numba sets its config at run time
    for function in _SHARED:
        register_jitable(function)
    return numba


class FlightCode:
    """A function compiled by numba at its first call (or loaded from the disk cache); called from Python."""

    def __init__(self, function: Callable[..., Any]) -> None:
        functools.update_wrapper(self, function)
        self.py_func = function
        self.dispatcher: Any = None  # numba's, once compiled

    def __call__(self, *args: Any) -> Any:
        dispatcher = self.dispatcher
        if dispatcher is None:
            dispatcher = self.dispatcher = _numba().njit(cache=True)(self.py_func)
        return dispatcher(*args)


COMPILED: list[FlightCode] = []  # every `flight_code` function (for `freeze`, and the tests)


def flight_code(function: F) -> F:
    """`function` compiled on its first call, with the same signature. Compiled code cannot call it: a helper
    that compiled code calls is `shared_maths`."""
    compiled = FlightCode(function)
    COMPILED.append(compiled)
    return cast(F, compiled)


def shared_maths(function: F) -> F:
    """`function` as it is for Python callers, compiled inline into the flight code that calls it."""
    _SHARED.append(function)
    if _numba.cache_info().currsize:  # defined after the first compile: known to numba at once
        _numba().extending.register_jitable(function)
    return function


def freeze() -> None:
    """No more compiling in this process of what has been compiled: a call with argument types not seen yet
    raises TypeError. (Functions never called, another controller's, stay as they are.)"""
    for compiled in COMPILED:
        if compiled.dispatcher is not None and compiled.dispatcher.signatures:
            compiled.dispatcher.disable_compile()
