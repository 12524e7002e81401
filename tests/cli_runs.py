"""`hil run` as a user types it, from the repository root, for the end-to-end tests."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def run(scenario: Path, runs: Path, *extra: str, timeout: float = 600) -> tuple[subprocess.CompletedProcess[str], Path]:
    """The finished process and its run directory (the newest in `runs`)."""
    result = subprocess.run([sys.executable, "-m", "hil.cli", "run", str(scenario), "--runs", str(runs), *extra],
                            capture_output=True, text=True, cwd=ROOT, timeout=timeout)
    return result, max(runs.iterdir())
