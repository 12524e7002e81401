"""Shared by the benchmarks: the command line with `--quick` (a smoke run, tests/test_benchmarks_smoke.py),
the shipped scenarios with a mission of a few seconds for it, a whole `hil run`'s real-time factor, and the same
idle CPUs for a reference and the runs measured against it."""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import yaml

from hil.host.idle_cpus import idle_cpus_polling
from hil.host.lifetime import die_with_parent
from hil.sweep.design import set_path

ROOT = Path(__file__).resolve().parent.parent
# what --quick changes in a shipped scenario, as a sweep's overrides: a 2 s mission judged from 1 s, 2 m up (a
# take-off of seconds), disarmed where it ends instead of landing; the same wind, the gusts inside the mission;
# the helix without its mass steps (at 10 s and 20 s)
_QUICK_MISSION: dict[str, Any] = {"duration_s": 2.0, "reference.altitude_m": 2.0, "expect.settle_s": 1.0,
                                  "end": "disarm"}
QUICK_OVERRIDES: dict[str, dict[str, Any]] = {
    "hover": _QUICK_MISSION,
    "gust": {**_QUICK_MISSION, "wind.gusts[0].start_s": 0.5, "wind.gusts[1].start_s": 1.0},
    "paper_helix": {**_QUICK_MISSION, "payload": []},
}


def benchmark_parser(doc: str) -> argparse.ArgumentParser:
    """The script's parser with `--quick`, so that every benchmark can be run once in seconds to show it
    still works against the current code."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="smoke run: the smallest sizes (in place of any given) that still print every figure; "
                             "the figures then mean nothing")
    return parser


def scenario_file(name: str, quick: bool, scratch: Path) -> Path:
    """scenarios/NAME.yaml, or with `quick` a copy of it written into `scratch` with the overrides above."""
    shipped = ROOT / "scenarios" / f"{name}.yaml"
    if not quick:
        return shipped
    data = yaml.safe_load(shipped.read_text())
    for path, value in QUICK_OVERRIDES[name].items():
        set_path(data, path, value)
    short = scratch / shipped.name
    short.write_text(yaml.safe_dump(data, sort_keys=False))
    return short


_runs_extra: list[str] = []  # what every `hil run` of `run_metrics` is given besides its own options


@contextmanager
def idle_cpus_alike(power_save: bool) -> Iterator[str]:
    """A reference and the lockstep runs against it on the same idle CPUs: a lockstep `hil run` keeps them polling
    while it flies (`hil/host/idle_cpus.py`), which a reference (PX4 and a minimal simulator) would not, so the
    benchmark holds the same request while the block runs; or, with `power_save`, none anywhere (`--power-save`
    for every run). Yields what holds, to be printed: it moves every figure."""
    _runs_extra[:] = ["--power-save"] if power_save else []
    with idle_cpus_polling("--power-save" if power_save else None) as note:
        yield note


def run_metrics(scenario: Path, extra: list[str], runs: Path, accept_exits: tuple[int, ...] = (0,),
                env: dict[str, str] | None = None) -> dict[str, Any]:
    """Fly `scenario` once as a user types it (telemetry on, no report) into the empty directory `runs`; the
    run's metrics. An exit outside `accept_exits` is printed with its reason."""
    result = subprocess.run([sys.executable, "-m", "hil", "run", "--no-report", str(scenario), "--runs", str(runs),
                             *extra, *_runs_extra], capture_output=True, text=True, cwd=ROOT, timeout=900, env=env,
                            preexec_fn=die_with_parent)
    if not runs.is_dir():
        raise RuntimeError(f"hil run {scenario} {' '.join(extra)} exited {result.returncode}: {result.stderr[-500:]}")
    run_dir = next(p for p in runs.iterdir() if p.is_dir())
    metrics: dict[str, Any] = json.loads((run_dir / "metrics.json").read_text())
    if result.returncode not in accept_exits:
        print(f"  ({scenario.name} {' '.join(extra)} exited {result.returncode}: {metrics.get('reason')})")
    return metrics


def realtime_factor(scenario: Path, extra: list[str], runs: Path) -> float:
    """Fly `scenario` once into the empty directory `runs`; the run's own real-time factor (it must pass)."""
    metrics = run_metrics(scenario, extra, runs)
    if metrics["exit_code"] != 0:
        raise RuntimeError(f"hil run {scenario} {' '.join(extra)} exited {metrics['exit_code']}: {metrics['reason']}")
    return float(metrics["timing"]["realtime_factor"])
