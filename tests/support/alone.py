"""Tests that measure wall-clock time run alone under pytest-xdist.

`make test` runs the suite on two workers (a lockstep flight keeps about one core busy, a real-time HITL flight
far less, so two at a time nearly halve the suite on two cores). A test whose assertion is a wall-clock figure
(an exit within 2 s, a late step's lateness, a 1 Hz heartbeat) is marked `alone`: it waits until the other
workers' running tests end, and none starts beside it. Two file locks shared by the workers do it, a turnstile
and a room: every test passes the turnstile and holds the room shared; an `alone` test holds the turnstile
(so no test enters after it) until it holds the room alone. The locks live in the session's temporary
directory, which the workers share (each has its own below it). Without xdist there is no one to wait for.
"""

from __future__ import annotations

import fcntl
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest


@contextmanager
def _locked(path: Path, mode: int) -> Iterator[None]:
    with path.open("a") as handle:
        fcntl.flock(handle, mode)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


@contextmanager
def room(config: pytest.Config, alone: bool) -> Iterator[None]:
    """Holds the session's room for one test: shared, or (`alone`) to itself."""
    if not hasattr(config, "workerinput"):  # not an xdist worker
        yield
        return
    session_dir = Path(config.option.basetemp).parent  # xdist gives worker gwN the basetemp <session>/gwN
    turnstile, shared_room = session_dir / "alone.turnstile", session_dir / "alone.room"
    if alone:
        with _locked(turnstile, fcntl.LOCK_EX), _locked(shared_room, fcntl.LOCK_EX):
            yield
        return
    with _locked(turnstile, fcntl.LOCK_EX):
        pass
    with _locked(shared_room, fcntl.LOCK_SH):
        yield
