"""Work started on a thread of its own, beside what the caller does meanwhile (a board's start: a process start-up's
worth of waiting), and the call that waits for it."""

from __future__ import annotations

import threading
from collections.abc import Callable


def beside(work: Callable[[], None], name: str) -> Callable[[], None]:
    """Start `work` now on a daemon thread; returns the function that waits for it and raises what it raised
    (as often as it is called)."""
    failure: list[BaseException] = []

    def run() -> None:
        try:
            work()
        except BaseException as exc:  # raised where the caller waits for it
            failure.append(exc)

    thread = threading.Thread(target=run, name=name, daemon=True)
    thread.start()

    def join() -> None:
        thread.join()
        if failure:
            raise failure[0]

    return join
