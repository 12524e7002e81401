"""Samples per minute of `hil sweep sweeps/gust_monte_carlo.yaml --limit N` with 2 workers against 1 worker
on the same machine, measured in one run (the LocalCluster's start-up included, as a user waits for it),
beside the machine's own ceiling for that ratio: two bare `hil run scenarios/gust.yaml` side by side against
one alone (no Dask, nothing shared). On a VM whose two vCPUs are not two free cores that ceiling is
well under 2, and no scheduling of the sweep can beat it.

Usage: python benchmarks/sweep_throughput.py [--samples N] [--rounds R] [--quick]
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from run_timing import ROOT, benchmark_parser, scenario_file

from hil.host.lifetime import die_with_parent
from hil.sweep import SweepSpec, load_sweep, run_spec

SWEEP = ROOT / "sweeps" / "gust_monte_carlo.yaml"
# --quick: one sample per sweep, its 25 s mission cut to 2 s 2 m up (the gust and the payload inside it), disarmed
# where it ends
QUICK_OVERRIDES = {"duration_s": 2.0, "reference.altitude_m": 2.0, "expect.settle_s": 1.0, "end": "disarm",
                   "wind.gusts[0].start_s": 0.5, "payload[0].t_s": 1.5}


def samples_per_minute(spec: SweepSpec, jobs: int, samples: int, out: Path) -> float:
    started = time.monotonic()
    outcome = run_spec(spec, out, jobs=jobs, limit=samples)
    assert len(outcome.rows) == samples and not outcome.interrupted
    return samples / ((time.monotonic() - started) / 60)


def bare_runs_wall_s(scenario: Path, count: int, runs: Path) -> float:
    """Wall time of `count` plain `hil run`s of `scenario` started together."""
    started = time.monotonic()
    procs = [subprocess.Popen([sys.executable, "-m", "hil", "run", "--no-report", str(scenario),
                               "--runs", str(runs / str(k))], cwd=ROOT, stdout=subprocess.DEVNULL,
                              preexec_fn=die_with_parent)  # noqa: PLW1509 - dies with the benchmark
             for k in range(count)]
    assert all(proc.wait() == 0 for proc in procs)
    return time.monotonic() - started


def main() -> int:
    parser = benchmark_parser(__doc__)
    parser.add_argument("--samples", type=int, default=8)
    parser.add_argument("--rounds", type=int, default=2)
    args = parser.parse_args()
    spec = load_sweep(SWEEP)
    if args.quick:
        spec = spec.model_copy(update={"overrides": {**spec.overrides, **QUICK_OVERRIDES}})
    samples, rounds = (1, 1) if args.quick else (args.samples, args.rounds)
    one, two, ceiling = [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        gust = scenario_file("gust", args.quick, Path(tmp))
        for n in range(rounds):
            one.append(samples_per_minute(spec, 1, samples, Path(tmp) / f"one{n}"))
            two.append(samples_per_minute(spec, 2, samples, Path(tmp) / f"two{n}"))
            ceiling.append(2 * bare_runs_wall_s(gust, 1, Path(tmp) / f"bare1_{n}")
                           / bare_runs_wall_s(gust, 2, Path(tmp) / f"bare2_{n}"))
            print(f"round {n + 1}: 1 worker {one[-1]:.1f} samples/min, 2 workers {two[-1]:.1f} samples/min, "
                  f"bare runs 2 vs 1 {ceiling[-1]:.2f}")
    a, b = statistics.median(one), statistics.median(two)
    print(f"\n{os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f}; {samples} samples per sweep, "
          f"medians of {rounds} rounds")
    print(f"2 workers {b:.1f} samples/min, 1 worker {a:.1f} samples/min: ratio {b / a:.2f}")
    print(f"machine ceiling (two bare hil runs side by side against one): ratio {statistics.median(ceiling):.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
