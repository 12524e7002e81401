"""Samples per minute of `hil sweep sweeps/gust_monte_carlo.yaml --limit N` with 2 workers against 1 worker
on the same machine, measured in one run (the LocalCluster's start-up included, as a user waits for it).

Usage: python benchmarks/sweep_throughput.py [--samples N] [--rounds R]
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

from hil.sweep import run_sweep

SWEEP = Path(__file__).resolve().parent.parent / "sweeps" / "gust_monte_carlo.yaml"


def samples_per_minute(jobs: int, samples: int, out: Path) -> float:
    started = time.monotonic()
    outcome = run_sweep(SWEEP, out, jobs=jobs, limit=samples)
    assert len(outcome.rows) == samples and not outcome.interrupted
    return samples / ((time.monotonic() - started) / 60)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=8)
    parser.add_argument("--rounds", type=int, default=2)
    args = parser.parse_args()
    one, two = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for n in range(args.rounds):
            one.append(samples_per_minute(1, args.samples, Path(tmp) / f"one{n}"))
            two.append(samples_per_minute(2, args.samples, Path(tmp) / f"two{n}"))
            print(f"round {n + 1}: 1 worker {one[-1]:.1f} samples/min, 2 workers {two[-1]:.1f} samples/min")
    a, b = statistics.median(one), statistics.median(two)
    print(f"\n{os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f}; {args.samples} samples per sweep, "
          f"medians of {args.rounds} rounds")
    print(f"2 workers {b:.1f} samples/min, 1 worker {a:.1f} samples/min: ratio {b / a:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
