"""A progress bar with simulated time and real-time factor, when stdout is a terminal."""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager

from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn


@contextmanager
def progress_printer(name: str) -> Iterator[Callable[[str, float, float, float], None] | None]:
    """The whole run: the phase by name (preflight and landing too), the bench clock, the share of
    take-off and mission flown, the real-time factor."""
    if not sys.stdout.isatty():
        yield None
        return
    columns = (TextColumn("[bold]{task.description}"), TextColumn("{task.fields[phase]:>9}"), BarColumn(),
               TextColumn("{task.fields[sim]}"), TextColumn("{task.fields[rtf]}"), TimeElapsedColumn())
    with Progress(*columns, transient=True) as bar:
        task = bar.add_task(name, total=1.0, phase="", sim="", rtf="")

        def update(phase: str, sim_s: float, flown: float, rtf: float) -> None:
            bar.update(task, completed=flown, phase=phase, sim=f"{sim_s:7.1f} s sim", rtf=f"{rtf:5.1f}x real time")

        yield update


@contextmanager
def sample_progress(name: str) -> Iterator[Callable[[int, int], None] | None]:
    """A bar over a sweep's samples (finished / total), when stdout is a terminal."""
    if not sys.stdout.isatty():
        yield None
        return
    columns = (TextColumn("[bold]{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total} samples"),
               TimeElapsedColumn())
    with Progress(*columns) as bar:
        task = bar.add_task(name, total=None)

        def update(done: int, total: int) -> None:
            bar.update(task, completed=done, total=total)

        yield update
