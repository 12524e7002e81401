"""How far two flights of one scenario are apart: the largest difference of the true position (m) and attitude
(deg) at the same simulated time, from their recordings' `hil/state` channel.

A deliberate numerical change (a clock, a geodesy) cannot keep the recordings bit for bit; this is how it is
shown to keep the flight: `python -m tests.support.recording_agreement OLD_RUN_DIR NEW_RUN_DIR`, or over every shipped
scenario with `python -m tests.support.recording_agreement --shipped OLD_REVISION` (flies both sides here).
"""

from __future__ import annotations

import argparse
import math
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import orjson
from mcap.reader import make_reader

from tests.support.recording_digest import NOT_REPRODUCIBLE, ROOT, shipped_scenarios


def true_states(run_dir: Path) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """t_us → (pos_ned m, rpy rad) of the recording's true state."""
    states = {}
    with open(run_dir / "recording.mcap", "rb") as f:
        for _, _, message in make_reader(f).iter_messages(topics=["hil/state"]):
            sample = orjson.loads(message.data)
            states[sample["t_us"]] = (np.array(sample["pos_ned"]), np.array(sample["rpy"]))
    return states


def agreement(old: Path, new: Path) -> tuple[float, float, int]:
    """(largest position difference m, largest attitude difference deg, steps compared) over the common steps."""
    a, b = true_states(old), true_states(new)
    common = sorted(a.keys() & b.keys())
    if not common:
        raise ValueError(f"{old} and {new} share no step")
    dpos = max(float(np.max(np.abs(a[t][0] - b[t][0]))) for t in common)
    datt = max(float(np.max(np.abs(np.angle(np.exp(1j * (a[t][1] - b[t][1])))))) for t in common)
    return dpos, math.degrees(datt), len(common)


def _fly(checkout: Path, scenario: Path, runs: Path) -> Path:
    subprocess.run([sys.executable, "-m", "hil", "run", str(checkout / "scenarios" / scenario.name), "--runs",
                    str(runs), "--no-report", "--no-telemetry", "--no-gcs"], cwd=checkout, check=False,
                   stdout=subprocess.DEVNULL)
    return max(runs.iterdir())


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="*", type=Path, help="OLD_RUN_DIR NEW_RUN_DIR")
    parser.add_argument("--shipped", metavar="OLD_REVISION", help="fly every shipped scenario at it and here")
    args = parser.parse_args()
    if not args.shipped:
        dpos, datt, steps = agreement(*args.runs)
        print(f"{steps} steps: position within {dpos:.3g} m, attitude within {datt:.3g} deg")
        return 0
    with tempfile.TemporaryDirectory() as tmp:
        old = Path(tmp) / "old"
        subprocess.run(["git", "worktree", "add", "--detach", str(old), args.shipped], cwd=ROOT, check=True,
                       capture_output=True)
        try:
            for scenario in shipped_scenarios():
                if scenario.stem in NOT_REPRODUCIBLE:
                    continue
                dpos, datt, steps = agreement(_fly(old, scenario, Path(tmp) / f"old-{scenario.stem}"),
                                              _fly(ROOT, scenario, Path(tmp) / f"new-{scenario.stem}"))
                print(f"{scenario.stem}: {steps} steps, position within {dpos:.3g} m, attitude within {datt:.3g} deg",
                      flush=True)
        finally:
            subprocess.run(["git", "worktree", "remove", "--force", str(old)], cwd=ROOT, check=False)
    return 0


if __name__ == "__main__":
    sys.exit(main())
