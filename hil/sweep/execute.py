"""Running a sweep's samples on Dask: a LocalCluster of `jobs` worker processes by default, or any
running cluster. Each sample is a whole `hil run` (plant FMU, sensors, MAVLink on a pty, emulator) in a
subprocess of a worker, one at a time per worker, its emulator forked by the worker's warm fork server; its outcome
is a result, whatever the exit code.

The client writes each finished sample's `result.json` under OUT/samples/NNNN/ as it arrives, so a
stopped sweep keeps what finished and `--resume` flies only the rest.
"""

from __future__ import annotations

import json
import logging
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hil.boards.forked_emulator import warm_emulators_for_this_process
from hil.host.lifetime import die_with_parent
from hil.sweep.options import CONNECT_TIMEOUT_S

RESULT = "result.json"
SAMPLE_TIMEOUT_S = 3600.0  # a sample that runs longer than this is stopped and reported


@dataclass(frozen=True)
class SampleTask:
    """What a worker needs for one sample: plain data, so that it travels to any Dask worker."""

    index: int
    scenario_yaml: str
    sample_dir: str


def sample_dir(out: Path, index: int) -> Path:
    return out / "samples" / f"{index:05d}"


def run_command(sample_path: Path) -> list[str]:
    """The command that flies the sample alone (relative to the working directory where it lies below it)."""
    scenario = sample_path / "scenario.yaml"
    if scenario.is_relative_to(Path.cwd()):
        scenario = scenario.relative_to(Path.cwd())
    return ["hil", "run", str(scenario)]


def fly_sample(task: SampleTask) -> dict[str, Any]:
    """On a worker: fly the sample with `hil run` and return its outcome (exit code, reason, metrics). The
    worker's emulators come from one warm fork server, started with its first sample (~0.8 s of CPU less for
    each later one)."""
    warm_emulators_for_this_process()
    directory = Path(task.sample_dir)
    directory.mkdir(parents=True, exist_ok=True)
    scenario = directory / "scenario.yaml"
    scenario.write_text(task.scenario_yaml)
    runs = directory / "runs"
    started = time.monotonic()
    try:
        result = subprocess.run([sys.executable, "-m", "hil", "run", str(scenario), "--runs", str(runs),
                                 "--no-telemetry", "--no-gcs", "--no-report", "--keep-failed"],
                                capture_output=True, text=True,
                                preexec_fn=die_with_parent, timeout=SAMPLE_TIMEOUT_S)
        code, stderr = result.returncode, result.stderr
    except subprocess.TimeoutExpired:
        code, stderr = 124, f"stopped after {SAMPLE_TIMEOUT_S:g} s"
    wall_s = time.monotonic() - started
    run_dirs = sorted(p for p in runs.iterdir() if p.is_dir()) if runs.is_dir() else []
    metrics_file = run_dirs[-1] / "metrics.json" if run_dirs else None
    metrics = json.loads(metrics_file.read_text()) if metrics_file and metrics_file.is_file() else {}
    reason = metrics.get("reason") or (stderr.strip().splitlines() or ["no output"])[-1]
    return {"index": task.index, "exit_code": code, "reason": reason, "wall_s": wall_s,
            "run_dir": str(run_dirs[-1]) if run_dirs else "", "metrics": metrics}


def finished_results(out: Path) -> dict[int, dict[str, Any]]:
    """Results already on disk (from an earlier, stopped sweep), by sample index."""
    found = {}
    for path in (out / "samples").glob(f"*/{RESULT}"):
        try:
            result = json.loads(path.read_text())
            found[int(result["index"])] = result
        except (OSError, ValueError, KeyError, TypeError):  # cut short or foreign: the sample flies again
            continue
    return found


class ClusterUnreachable(OSError):
    """No Dask scheduler answered at the --cluster address in time."""


@contextmanager
def dask_client(jobs: int, address: str | None) -> Iterator[Any]:
    """A client of the cluster at `address` (ClusterUnreachable if none answers within CONNECT_TIMEOUT_S), or
    of a LocalCluster of `jobs` single-threaded processes."""
    from dask.distributed import Client, LocalCluster

    if address is not None:
        try:
            client = Client(address, timeout=CONNECT_TIMEOUT_S)
        except OSError as exc:  # refused or silent: dask retries until its timeout, then says so
            raise ClusterUnreachable(f"--cluster {address}: no Dask scheduler answered within "
                                     f"{CONNECT_TIMEOUT_S:g} s ({str(exc).splitlines()[0]})") from None
        with client:
            yield client
        return
    with LocalCluster(n_workers=jobs, threads_per_worker=1, processes=True, dashboard_address=None,
                      silence_logs=logging.ERROR) as cluster, Client(cluster) as client:
        yield client


def run_tasks(client: Any, tasks: list[SampleTask], out: Path, on_result: Callable[[dict[str, Any]], None]) -> None:
    """Submit every task to the client's cluster, record each result as it arrives; Ctrl-C (or SIGTERM)
    cancels what has not finished and raises KeyboardInterrupt. The signal only sets a flag that the loop
    reads twice a second: Dask's own waits may swallow a KeyboardInterrupt raised inside them."""
    from dask.distributed import wait

    with _stop_requested() as stop:
        pending = {client.submit(fly_sample, task, key=f"hil-sample-{out.name}-{task.index}-{time.time_ns()}",
                                 pure=False) for task in tasks}
        while pending:
            if stop.is_set():
                client.cancel(list(pending))
                raise KeyboardInterrupt("Ctrl-C")
            try:
                done, pending = wait(list(pending), timeout=0.5, return_when="FIRST_COMPLETED")
            except TimeoutError:  # nothing finished in this half second
                continue
            pending = set(pending)
            for future in done:
                result = future.result()
                directory = sample_dir(out, result["index"])  # on another machine's worker it may not exist here
                directory.mkdir(parents=True, exist_ok=True)
                (directory / RESULT).write_text(json.dumps(result, default=str))
                on_result(result)


@contextmanager
def _stop_requested() -> Iterator[threading.Event]:
    stop = threading.Event()
    if threading.current_thread() is not threading.main_thread():
        yield stop
        return
    previous = {sig: signal.signal(sig, lambda *_: stop.set()) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield stop
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
