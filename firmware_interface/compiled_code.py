"""Python compiled to machine code by numba for a hot path: one definition of each function, run natively.

A `CompiledCode` is a group of sources (a package, or a few modules) whose functions are compiled together:

- `compiled`: an entry point Python calls (compiled at its first call, or loaded from the disk cache).
- `inline`: a function compiled code calls (compiled into its callers), and plain Python for Python callers.

Once a group is frozen (`freeze`: after a process's warm-up) a function compiled for one signature is called
through that signature's machine code directly. numba's dispatcher otherwise works out every argument's type on
every call to pick the machine code, ~0.3 µs a call plus ~0.03 µs an argument (a control law's 22 arguments: 1.6
µs a call against 1.0 direct), and a step makes about six such calls on each side of the link. Called directly, an
argument of another type would not be refused but read wrongly (an int64 array as float64, a strided view as
contiguous); so every `CHECK_EVERY`-th call, and the first after the freeze, still goes through the dispatcher,
which raises TypeError for types it was not compiled for, as it did for every call before.

Compiled code is cached on disk, so a compile (seconds) is paid once, by the first process that runs it. numba
keys its cache on the file of the calling function only, so an edited `inline` function in another file would
leave stale machine code: each group's cache directory is named after a digest of every one of its sources and
numba's version instead, and any change compiles afresh. numba itself is imported at the first compiled call
(~0.2 s): a process that runs none never loads it.

Rules for compiled code: numbers and float64/int64/uint8 arrays in and out, no Python objects; matrix products
spelled out (numba's `@` needs a BLAS it does not ship).
"""

from __future__ import annotations

import functools
import hashlib
import os
import threading
from collections.abc import Callable, Iterable
from importlib.metadata import version
from pathlib import Path
from types import ModuleType
from typing import Any, TypeVar, cast

F = TypeVar("F", bound=Callable[..., Any])
_INLINE: list[Callable[..., Any]] = []  # every group's `inline` functions, known to numba before any compile
_CACHE_DIR_SETTING = threading.Lock()  # held while numba.config.CACHE_DIR names one group's directory
CHECK_EVERY = 64  # a frozen function's calls made through the type-checking dispatcher: one in this many


@functools.cache
def _numba() -> ModuleType:
    """numba, imported at the first compile (or cache load) of any group."""
    import numba
    from numba.extending import register_jitable

    for function in _INLINE:
        register_jitable(function)
    return numba


class CompiledCode:
    """The compiled functions of a set of sources, cached in a directory of their own."""

    def __init__(self, name: str, sources: Iterable[Path]) -> None:
        self.name = name
        self.sources = tuple(sources)  # files, or directories whose *.py files all count
        self.entries: list[_Entry] = []

    @functools.cached_property
    def cache_dir(self) -> Path:
        """Where the compiled code of exactly these sources lives (XDG cache, ~/.cache by default)."""
        digest = hashlib.sha256(version("numba").encode())
        for source in self.sources:
            for path in sorted(source.rglob("*.py")) if source.is_dir() else [source]:
                digest.update(path.relative_to(source.parent).as_posix().encode())
                digest.update(path.read_bytes())
        root = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
        return root / "hil-bench" / f"{self.name}-{digest.hexdigest()[:16]}"

    def compiled(self, function: F) -> F:
        """`function` compiled at its first call, with the same signature. Compiled code cannot call it: what
        compiled code calls is `inline`."""
        entry = _Entry(function, self)
        self.entries.append(entry)
        return cast(F, entry)

    @staticmethod
    def inline(function: F) -> F:
        """`function` as it is for Python callers, compiled into the compiled code that calls it."""
        _INLINE.append(function)
        if _numba.cache_info().currsize:  # numba is loaded already: known to it at once
            _numba().extending.register_jitable(function)
        return function

    def freeze(self) -> None:
        """No more compiling of what has been compiled: a call with argument types not seen yet raises TypeError
        (a type never flown would otherwise compile silently, seconds long, in the middle of a flight). A function
        compiled for one signature is called directly from now on, its types checked one call in `CHECK_EVERY`."""
        for entry in self.entries:
            dispatcher = entry.dispatcher
            if dispatcher is not None and dispatcher.signatures:
                dispatcher.disable_compile()
                if len(dispatcher.overloads) == 1:
                    entry.direct = next(iter(dispatcher.overloads.values())).entry_point


class _Entry:
    """A `compiled` function: numba's dispatcher, made at the first call with the group's cache directory."""

    def __init__(self, function: Callable[..., Any], group: CompiledCode) -> None:
        functools.update_wrapper(self, function)
        self.py_func = function
        self.group = group
        self.dispatcher: Any = None
        self.direct: Any = None  # the one signature's machine code, once the group is frozen
        self.unchecked_calls = 0  # calls left before the next one through the dispatcher

    def __call__(self, *args: Any) -> Any:
        if self.unchecked_calls > 0:  # `> 0`, not truth: two threads counting down at once may pass 0
            self.unchecked_calls -= 1
            return self.direct(*args)
        dispatcher = self.dispatcher
        if dispatcher is None:
            dispatcher = self.dispatcher = self._make()
        result = dispatcher(*args)  # types checked: TypeError, once frozen, for a type not compiled
        if self.direct is not None:
            self.unchecked_calls = CHECK_EVERY - 1
        return result

    def _make(self) -> Any:
        """numba's cache directory is one global setting, read twice as a dispatcher picks its cache: set for this
        group and put back under a lock, or another thread's put-back between the two reads left the dispatcher's
        cache in the working directory (a `loop_<hash>` directory in the checkout, and a compile every run)."""
        numba = _numba()
        with _CACHE_DIR_SETTING:
            previous = numba.config.CACHE_DIR
            numba.config.CACHE_DIR = str(self.group.cache_dir)
            try:
                return numba.njit(cache=True)(self.py_func)
            finally:
                numba.config.CACHE_DIR = previous
