"""Lockstep real-time factor of PX4 SITL driven by a minimal simulator, next to `hil run
scenarios/hover.yaml --px4 DIR` on the same PX4 build, measured in the same run, and their ratio.

The minimal simulator is the reference for PX4's own cost: it sends one HIL_SENSOR (a vehicle at
rest, with a little noise so PX4 does not call its sensors stale) and a HIL_GPS at 10 Hz, waits for
the HIL_ACTUATOR_CONTROLS that echoes that step's time, and repeats; no plant, no sensor models,
no recording. Rounds alternate the two so that the machine's load hits both alike; medians are
printed. Both run with idle CPUs kept polling, as a lockstep `hil run` keeps them (`--power-save`: halting, both).
Usage: python benchmarks/px4_sitl_speed.py [--px4 DIR | HIL_PX4_DIR=...] [--rounds N] [--power-save] [--quick]
"""

from __future__ import annotations

import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from run_timing import benchmark_parser, idle_cpus_alike, run_metrics, scenario_file  # noqa: E402

from firmware_interface import hil_codec as codec  # noqa: E402
from hil.boards.px4.build import Px4Build, find_build  # noqa: E402
from hil.boards.px4_sitl import Px4SitlTarget  # noqa: E402
from hil.boards.target import LinkSettings  # noqa: E402
from hil.scenario.loader import load_scenario  # noqa: E402

RATE_HZ = 250
MINIMAL_SIM_S, QUICK_MINIMAL_SIM_S = 60.0, 5.0
GPS_EVERY = RATE_HZ // 10
HOME = (47.397742, 8.545594, 488.0)
MAG_FRD_T = (2.16e-5, 0.13e-5, 4.28e-5)  # roughly the earth field at PX4's default home, vehicle facing north


def minimal_simulator(build: Px4Build, scratch: Path, sim_s: float) -> tuple[float, float]:
    """PX4 SITL stepped by the simplest simulator there is for `sim_s`; returns simulated s per wall s and
    PX4's own CPU µs per step (measured as the bench measures its board's, `timing.board_cpu_us_per_step`)."""
    handle = Px4SitlTarget(build).attach(load_scenario(ROOT / "scenarios" / "hover.yaml"), scratch,
                                         LinkSettings(watchdog_s=2.0))
    session = handle.hil_session
    rng = np.random.default_rng(1)
    dt_us = 1_000_000 // RATE_HZ
    steps = int(sim_s * RATE_HZ)
    cpu_start_s = handle.cpu_s() or 0.0  # the bench's own figure starts here too: at its first step
    try:
        t_us = 0
        started = None
        for step in range(steps):
            t_us += dt_us
            noise = rng.normal(0.0, 1.0, 10)
            readings = codec.SensorReadings(
                t_us, (0.01 * noise[0], 0.01 * noise[1], -9.80665 + 0.01 * noise[2]),
                (1e-3 * noise[3], 1e-3 * noise[4], 1e-3 * noise[5]),
                tuple(b + 2e-8 * n for b, n in zip(MAG_FRD_T, noise[6:9], strict=True)),
                codec.Baro(95598.0 + noise[9], 15.0, 0.0))
            gps = None
            if step % GPS_EVERY == 0:
                gps = codec.GpsFix(t_us, *HOME, (0.0, 0.0, 0.0), 1.0, 1.0)
            session.exchange(readings, gps)
            if started is None and session.lockstep:
                started, t0_us = time.perf_counter(), t_us
        assert started is not None, "PX4 never entered lockstep"
        rtf = (t_us - t0_us) * 1e-6 / (time.perf_counter() - started)
        cpu_s = handle.cpu_s()
        assert cpu_s is not None, "PX4's CPU time is unreadable (/proc)"
        return rtf, (cpu_s - cpu_start_s) / steps * 1e6
    finally:
        handle.close()


def main() -> int:
    parser = benchmark_parser(__doc__)
    parser.add_argument("--px4", help="a px4_sitl_default build (default: from HIL_PX4_DIR)")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--power-save", action="store_true",
                        help="idle CPUs may sleep for every row (by default all rows run with them kept polling, as "
                             "hil run keeps them)")
    args = parser.parse_args()
    rounds = 1 if args.quick else args.rounds
    with tempfile.TemporaryDirectory() as tmp, idle_cpus_alike(args.power_save) as idle_note:
        print(f"idle CPUs, both rows alike: {idle_note}", flush=True)
        scratch = Path(tmp)
        if args.px4:
            build = Px4Build.locate(args.px4, "--px4")
        elif os.environ.get("HIL_PX4_DIR"):
            build = Px4Build.locate(find_build(Path(os.environ["HIL_PX4_DIR"]), "sitl", scratch), "HIL_PX4_DIR")
        else:
            print("px4_sitl_speed: give --px4 DIR or set HIL_PX4_DIR (see tests/support/px4_builds.py)",
                  file=sys.stderr)
            return 2
        hover = scenario_file("hover", args.quick, scratch)
        minimal, bench, breakdowns = [], [], []
        px4_cpu: dict[str, list[float]] = {"minimal": [], "bench": []}
        for round_no in range(rounds):
            rtf, cpu_us = minimal_simulator(build, scratch / f"min{round_no}",
                                            QUICK_MINIMAL_SIM_S if args.quick else MINIMAL_SIM_S)
            minimal.append(rtf)
            px4_cpu["minimal"].append(cpu_us)
            metrics = run_metrics(hover, ["--px4", str(build.root)], scratch / f"bench{round_no}" / "runs")
            bench.append(metrics["timing"]["realtime_factor"])
            breakdowns.append(metrics["timing"]["breakdown_us_per_step"])
            px4_cpu["bench"].append(metrics["timing"]["board_cpu_us_per_step"])
            print(f"round {round_no + 1}: PX4 + minimal simulator {minimal[-1]:.1f}x, "
                  f"hil run hover --px4 {bench[-1]:.1f}x")
    ref, ours = statistics.median(minimal), statistics.median(bench)
    cpu = {name: statistics.median(values) for name, values in px4_cpu.items()}
    print(f"\nload average {os.getloadavg()[0]:.2f}; medians of {rounds} rounds")
    print(f"{'run':<52} {'real-time factor':>16} {'ratio':>7}  PX4's own CPU per step")
    print(f"{'PX4 v1.15.4 SITL + minimal simulator':<52} {ref:>15.1f}x {1.0:>7.2f}  {cpu['minimal']:.0f} us")
    print(f"{'hil run scenarios/hover.yaml --px4 DIR':<52} {ours:>15.1f}x {ours / ref:>7.2f}  {cpu['bench']:.0f} us")
    print("\nbench per step (us, median over rounds):")
    for key in breakdowns[0]:
        print(f"  {key:<26} {statistics.median(b[key] for b in breakdowns):8.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
