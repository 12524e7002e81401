"""The options of a sweep (`hil sweep`, and `hil compare`, which is one), checked before anything starts:
each problem one line naming the option."""

from __future__ import annotations

import os
import re
from pathlib import Path

from hil.host.addresses import unresolved
from hil.host.paths import unwritable

MAX_JOBS_PER_CORE = 4  # each worker flies one run at a time, about one core (the bench and its board alternate)
CONNECT_TIMEOUT_S = 10.0  # to reach a --cluster scheduler: a refused or silent one is a board-kind failure
_CLUSTER = re.compile(r"(?:(?P<scheme>[a-z]+)://)?(?P<host>\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9_.-]+):(?P<port>\d{1,5})")
_SCHEMES = ("tcp", "tls", "ws", "wss", "ucx")


def max_jobs() -> int:
    return MAX_JOBS_PER_CORE * (os.cpu_count() or 1)


def is_sweep_dir(out: Path) -> bool:
    """A sweep has written here: its table, or the directory of its samples."""
    return (out / "sweep.parquet").is_file() or (out / "samples").is_dir()


def _cluster_problem(address: str) -> str | None:
    match = _CLUSTER.fullmatch(address)
    if match is None:
        return f"--cluster {address}: expected a Dask scheduler address, e.g. tcp://192.0.2.5:8786"
    if match["scheme"] not in (None, *_SCHEMES):
        return f"--cluster {address}: unknown protocol {match['scheme']!r}; expected one of {', '.join(_SCHEMES)}"
    if not 1 <= int(match["port"]) <= 65535:
        return f"--cluster {address}: port {match['port']} is not in 1-65535"
    reason = unresolved(match["host"])
    return f"--cluster {address}: {reason}" if reason else None


def _out_problem(out: Path, resume: bool) -> str | None:
    if reason := unwritable(out):
        return f"--out {out}: {reason}"
    if resume and not out.is_dir():
        return f"--resume: {out} does not exist; nothing to resume (give the --out of the stopped sweep)"
    if resume and not is_sweep_dir(out):
        return f"--resume: {out} is not a sweep's results directory (no sweep.parquet, no samples/)"
    return None


def option_problems(jobs: int, limit: int | None, cluster: str | None, out: Path, resume: bool) -> list[str]:
    """One line per option a sweep cannot use."""
    problems = []
    if not 1 <= jobs <= max_jobs():
        problems.append(f"--jobs {jobs}: expected 1 to {max_jobs()} worker processes on this machine "
                        f"({MAX_JOBS_PER_CORE} per core)")
    if limit is not None and limit < 1:
        problems.append(f"--limit {limit}: expected a number of samples of at least 1")
    if cluster is not None and (reason := _cluster_problem(cluster)):
        problems.append(reason)
    if reason := _out_problem(out, resume):
        problems.append(reason)
    return problems
