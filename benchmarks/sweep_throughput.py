"""Samples per minute of `hil sweep sweeps/gust_monte_carlo.yaml --limit N` with 2 workers against 1 worker
on the same machine, measured in one run (the LocalCluster's start-up included, as a user waits for it).

Usage: python benchmarks/sweep_throughput.py [--samples N] [--rounds R] [--quick]
"""

from __future__ import annotations

import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

from run_timing import ROOT, benchmark_parser

from hil.sweep import SweepSpec, load_sweep, run_spec

SWEEP = ROOT / "sweeps" / "gust_monte_carlo.yaml"
# --quick: one sample per sweep, its 25 s mission cut to 6 s 2 m up (the gust and the payload inside it)
QUICK_OVERRIDES = {"duration_s": 6.0, "reference.altitude_m": 2.0, "wind.gusts[0].start_s": 1.0, "payload[0].t_s": 4.0}


def samples_per_minute(spec: SweepSpec, jobs: int, samples: int, out: Path) -> float:
    started = time.monotonic()
    outcome = run_spec(spec, out, jobs=jobs, limit=samples)
    assert len(outcome.rows) == samples and not outcome.interrupted
    return samples / ((time.monotonic() - started) / 60)


def main() -> int:
    parser = benchmark_parser(__doc__)
    parser.add_argument("--samples", type=int, default=8)
    parser.add_argument("--rounds", type=int, default=2)
    args = parser.parse_args()
    spec = load_sweep(SWEEP)
    if args.quick:
        spec = spec.model_copy(update={"overrides": {**spec.overrides, **QUICK_OVERRIDES}})
    samples, rounds = (1, 1) if args.quick else (args.samples, args.rounds)
    one, two = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for n in range(rounds):
            one.append(samples_per_minute(spec, 1, samples, Path(tmp) / f"one{n}"))
            two.append(samples_per_minute(spec, 2, samples, Path(tmp) / f"two{n}"))
            print(f"round {n + 1}: 1 worker {one[-1]:.1f} samples/min, 2 workers {two[-1]:.1f} samples/min")
    a, b = statistics.median(one), statistics.median(two)
    print(f"\n{os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f}; {samples} samples per sweep, "
          f"medians of {rounds} rounds")
    print(f"2 workers {b:.1f} samples/min, 1 worker {a:.1f} samples/min: ratio {b / a:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
