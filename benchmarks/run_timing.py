"""Shared by the benchmarks that compare whole `hil run`s: run one, read its real-time factor."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def realtime_factor(scenario: str, extra: list[str], runs: Path) -> float:
    """Fly `scenario` once into the empty directory `runs`; the run's own real-time factor."""
    subprocess.run([sys.executable, "-m", "hil.cli", "run", scenario, "--runs", str(runs), "--no-report", *extra],
                   check=True, cwd=ROOT, stdout=subprocess.DEVNULL)
    run_dir = next(p for p in runs.iterdir() if p.is_dir())
    return json.loads((run_dir / "metrics.json").read_text())["timing"]["realtime_factor"]
