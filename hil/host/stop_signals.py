"""The signals that stop a run, and the few writes they must not cut in half.

Ctrl-C, SIGTERM (timeout, systemd, CI, Docker) and SIGHUP (a closed terminal) stop a run the same way:
the first raises KeyboardInterrupt where the run is, so that it lands and closes its files; the next
one, while the run closes, only says that it is closing (cutting that short would orphan PX4 and lose
the flight); another one quits at once, saying what may then be incomplete.

A KeyboardInterrupt raised inside the MCAP writer's `add_message` leaves half a record in the open
chunk, and the finished file then fails to read. Such writes run `uninterrupted()`: a first signal that
arrives there is held and raised as the write ends.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from types import TracebackType

from hil.exit_codes import EXIT_INTERRUPTED

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


class _Gate:
    """Whether the main thread is inside a write that must end whole, and a stop held for its end."""

    def __init__(self) -> None:
        self.depth = 0
        self.held: str | None = None

    def __enter__(self) -> None:
        self.depth += 1

    def __exit__(self, kind: type[BaseException] | None, _value: BaseException | None,
                 _tb: TracebackType | None) -> None:
        self.depth -= 1
        if self.depth == 0 and self.held is not None and kind is None:
            reason, self.held = self.held, None
            raise KeyboardInterrupt(reason)


_gate = _Gate()
_first_stop: list[str] = []  # the first stop signal's reason while a run is under `stopped_by_signals`


def stop_requested() -> str | None:
    """The first stop signal's reason, if one came. The bench checks it every step: Python drops an exception
    raised where it cannot propagate (a ctypes callback, a `__del__`), and a stop that landed there must still
    stop the run."""
    return _first_stop[0] if _first_stop else None


def uninterrupted() -> _Gate:
    """A context for a write that a stop signal must not cut (a class, not a generator: it runs per step)."""
    return _gate


def _stop_reason(signum: int) -> str:
    return signal.Signals(signum).name.replace("SIGINT", "Ctrl-C")


@contextmanager
def stopped_by_signals() -> Iterator[None]:
    """One handler for the whole run, so that no second signal falls between two handlers."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    received: list[int] = []

    def on_signal(signum: int, _frame: object) -> None:
        received.append(signum)
        if len(received) == 1:
            reason = _stop_reason(signum)
            _first_stop.append(reason)
            if _gate.depth:
                _gate.held = reason
                return
            raise KeyboardInterrupt(reason)
        if len(received) == 2:
            print("\nclosing the run's files and stopping the board; again to quit at once", file=sys.stderr)
            return
        print("quitting at once: the recording, metrics and summary may be incomplete; the board may still run",
              file=sys.stderr)
        os._exit(EXIT_INTERRUPTED)

    previous = {sig: signal.signal(sig, on_signal) for sig in STOP_SIGNALS}
    try:
        yield
    finally:
        _gate.held = None
        _first_stop.clear()
        for sig, handler in previous.items():
            signal.signal(sig, handler)
