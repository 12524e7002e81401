"""Resident memory of the bench over a long simulated hover (default 2 h at 250 Hz, lockstep on the
emulator, recording and Zenoh on): RSS sampled every few seconds; prints growth after the first minute.

Usage: python benchmarks/memory_long_run.py [--hours H] [--quick]
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

from run_timing import ROOT, benchmark_parser

from hil.host.lifetime import die_with_parent

SAMPLE_S, WARM_UP_S = 5.0, 60.0  # RSS every SAMPLE_S; growth counts after WARM_UP_S of wall time
# --quick: a 6 s hover (a few seconds of wall time), sampled often enough to fill every figure
QUICK_DURATION_S, QUICK_SAMPLE_S, QUICK_WARM_UP_S = 6.0, 0.5, 2.0


def rss_mb(pid: int) -> float | None:
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    except FileNotFoundError:
        return None
    return None


def main() -> int:
    parser = benchmark_parser(__doc__)
    parser.add_argument("--hours", type=float, default=2.0)
    args = parser.parse_args()
    duration_s = QUICK_DURATION_S if args.quick else args.hours * 3600
    sample_s, warm_up_s = (QUICK_SAMPLE_S, QUICK_WARM_UP_S) if args.quick else (SAMPLE_S, WARM_UP_S)
    warm_up = "the first minute" if warm_up_s == 60 else f"the first {warm_up_s:g} s"
    with tempfile.TemporaryDirectory() as tmp:
        scenario = Path(tmp) / "long.yaml"
        scenario.write_text(f"name: long_hover\nduration_s: {duration_s:g}\nseed: 3\nend: disarm\n"
                            "reference: {type: hover, altitude_m: 10}\n"
                            "wind: {steady_ned: [2, 1, 0], turbulence: {intensity: light}}\n")
        bench = subprocess.Popen([sys.executable, "-m", "hil", "run", str(scenario), "--runs", tmp,
                                  "--no-report", "--no-gcs"], cwd=ROOT, stdout=subprocess.DEVNULL,
                                 preexec_fn=die_with_parent)  # noqa: PLW1509 - dies with the benchmark
        started, samples = time.monotonic(), []
        while bench.poll() is None:
            value = rss_mb(bench.pid)
            if value is not None:
                samples.append((time.monotonic() - started, value))
            time.sleep(sample_s)
        run_dir = next(p for p in Path(tmp).iterdir() if p.is_dir())
        summary = (run_dir / "summary.txt").read_text()
    after_minute = [mb for t, mb in samples if t >= warm_up_s]
    print(summary, end="")
    print(f"\nbench RSS: {samples[0][1]:.0f} MB at start, {after_minute[0]:.0f} MB after {warm_up}, "
          f"{max(after_minute):.0f} MB at most, {after_minute[-1]:.0f} MB at the end "
          f"({len(samples)} samples over {samples[-1][0]:.0f} s wall)")
    print(f"growth after {warm_up}: {max(after_minute) - after_minute[0]:+.1f} MB (target ≤ 20 MB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
