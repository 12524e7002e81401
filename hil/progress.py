"""A progress bar with simulated time and real-time factor, when stdout is a terminal."""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager

from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn


@contextmanager
def progress_printer(name: str) -> Iterator[Callable[[float, float, float], None] | None]:
    if not sys.stdout.isatty():
        yield None
        return
    columns = (TextColumn("[bold]{task.description}"), BarColumn(), TextColumn("{task.fields[sim]}"),
               TextColumn("{task.fields[rtf]}"), TimeElapsedColumn())
    with Progress(*columns, transient=True) as bar:
        task = bar.add_task(name, total=1.0, sim="", rtf="")

        def update(sim_s: float, total_s: float, rtf: float) -> None:
            bar.update(task, completed=min(sim_s / total_s, 1.0), sim=f"{sim_s:6.1f}/{total_s:.0f} s sim",
                       rtf=f"{rtf:5.1f}x real time")

        yield update
