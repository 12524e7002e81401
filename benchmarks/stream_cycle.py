"""A lockstep step's wall time by its place in the board's stream cycle: `hil run scenarios/gust.yaml` on the
emulator, as `make run` flies it, read back from its own recording.

Why: the board sends its state and control streams (ATTITUDE, LOCAL_POSITION_NED, ATTITUDE_TARGET,
DEBUG_FLOAT_ARRAY, ...) every few steps, all in one step's reply, as PX4's streams of one rate go out together.
That step's reply, the board's own work on it and the bench's recording of those messages in the next step make
some steps far longer than the others; the run's mean step, and so its real-time factor, pays for them. Each
step's wall time is in the recording (`hil/timing`); the board's messages carry the step that brought them.

Usage: python benchmarks/stream_cycle.py [--rounds N] [--quick]
"""

from __future__ import annotations

import statistics
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from run_timing import benchmark_parser, run_metrics, scenario_file

from hil.reports.rundata import read_channels

STREAM_CHANNEL = "board/attitude"  # one of the streams the emulator sends together
SETTLED_S = 10.0  # steps before this (start-up, take-off's first seconds) are left out; `--quick`: none


def cycle_of(recording: Path, settled_s: float) -> tuple[np.ndarray, np.ndarray, int]:
    """(each step's wall time in µs, its place in the stream cycle: 0 for the step whose reply brought the streams,
    the cycle's length in steps) of a run's recording."""
    channels = read_channels(recording, ("timing", STREAM_CHANNEL))
    steps = channels["timing"]
    t_us = np.array([s["t_us"] for s in steps])
    wall_us = np.array([s["step_wall_us"] for s in steps])
    streams = np.array([s["t_us"] for s in channels[STREAM_CHANNEL]])
    dt_us = int(np.median(np.diff(t_us)))
    period_steps = round(float(np.median(np.diff(streams))) / dt_us)
    phase_us = int(np.median(streams % (period_steps * dt_us)))
    place = ((t_us - phase_us) // dt_us) % period_steps
    kept = t_us >= settled_s * 1e6
    return wall_us[kept], place[kept], period_steps


def main() -> int:
    parser = benchmark_parser(__doc__)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    rounds = 1 if args.quick else args.rounds
    settled_s = 0.0 if args.quick else SETTLED_S
    by_place: dict[int, list[float]] = {}
    means, quiet_means, period = [], [], 0
    with tempfile.TemporaryDirectory() as tmp:
        gust = scenario_file("gust", args.quick, Path(tmp))
        for n in range(rounds):
            runs = Path(tmp) / f"runs{n}"
            rtf = run_metrics(gust, [], runs)["timing"]["realtime_factor"]
            wall_us, place, period = cycle_of(next(runs.iterdir()) / "recording.mcap", settled_s)
            medians = [float(np.median(wall_us[place == k])) for k in range(period)]
            for k, value in enumerate(medians):
                by_place.setdefault(k, []).append(value)
            means.append(statistics.mean(medians))  # a cycle's step, from each place's median (outliers aside)
            quiet_means.append(statistics.mean(sorted(medians)[:max(1, period // 2)]))  # the lighter half's
            print(f"round {n + 1}: {rtf:.2f}x real time, a cycle's step {means[-1]:.1f} us, {period} steps a cycle")
    print(f"\nscenarios/gust.yaml on the emulator, medians of {rounds} rounds; a step's wall time by its place in the "
          f"board's stream cycle (0: its reply brought the streams)")
    for k in range(period):
        print(f"  place {k}: {statistics.median(by_place[k]):7.1f} us (median step)")
    mean, quiet = statistics.median(means), statistics.median(quiet_means)
    print(f"a cycle's step {mean:.1f} us, the lighter half of its places {quiet:.1f} us: were every step as light, "
          f"the run would be {mean / quiet:.2f}x as fast")
    return 0


if __name__ == "__main__":
    sys.exit(main())
