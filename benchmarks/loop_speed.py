"""The bench's speed against PX4's own: one table, every row measured in the same run, ratios to PX4 SITL
driven by a minimal simulator (the cost of PX4 alone, benchmarks/px4_sitl_speed.py).

Rows: the reference; `hil run scenarios/hover.yaml --px4 DIR`; hover and gust on the emulator (full chain:
sensors, estimator, SMARC, MCAP at full rate, Zenoh on), gust again with `--spin-wait` (the bench and the emulator
poll for each other's frames: what a machine with a core free for each gains); the paper's 1 kHz helix per
controller; and the wall-clock pacing a Pixhawk gets (`--px4-hitl`, PX4's HITL code path on a pty). A round runs
them back to back; medians of the rounds are printed, with the load average, then where a bench step's time goes.
The reference and the lockstep rows run with idle CPUs kept polling, as a lockstep `hil run` keeps them, the paced
row with them halting, as a paced one leaves them (`--power-save`: halting for every row).
Usage: python benchmarks/loop_speed.py [--px4 DIR | HIL_PX4_DIR=...] [--rounds N] [--power-save] [--quick]
"""

from __future__ import annotations

import json
import os
import re
import select
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from px4_sitl_speed import MINIMAL_SIM_S, QUICK_MINIMAL_SIM_S, minimal_simulator  # noqa: E402
from run_timing import benchmark_parser, idle_cpus_alike, run_metrics, scenario_file  # noqa: E402

from firmware_interface.link import open_pty_pair  # noqa: E402
from hil.boards.px4.build import Px4Build, Px4SetupError, find_build  # noqa: E402
from hil.host.lifetime import die_with_parent  # noqa: E402
from hil.host.rt_priority import FIFO_PRIORITY  # noqa: E402

CONTROLLERS = ("smarc", "smpid", "backstepping")
STEP_US = 4000  # the paced run's step: scenarios/hover.yaml at 250 Hz
FLOOR_STALL_US = 1000  # a cyclictest wake-up this late is a stall of the machine (a quarter of a step)
# issue 36's acceptance: ratio to the reference, real-time factor, pacing p99 in us (gust's compass goal stays 2.0)
TARGETS = {"gust": 1.0, "px4 hover": 0.9, "helix": 5.0, "pacing p99": 200.0}


def one_round(sitl: Px4Build, hitl: Path, files: dict[str, Path], scratch: Path, quick: bool,
              power_save: bool) -> dict[str, Any]:
    """Every row once, back to back; real-time factors, the HITL run's pacing, and the bench breakdowns."""
    rtf: dict[str, float] = {}
    board_cpu: dict[str, float] = {}
    breakdown: dict[str, dict[str, float]] = {}
    runs = {"px4 hover": (files["hover"], ["--px4", str(sitl.root)]), "hover": (files["hover"], []),
            "gust": (files["gust"], []), "gust spin-wait": (files["gust"], ["--spin-wait"])}
    runs |= {f"helix {c}": (files["helix"], ["--controller", c]) for c in CONTROLLERS}
    with idle_cpus_alike(power_save):
        rtf["reference"], board_cpu["reference"] = minimal_simulator(sitl, scratch / "min",
                                                                     QUICK_MINIMAL_SIM_S if quick else MINIMAL_SIM_S)
        for name, (scenario, extra) in runs.items():
            # exit 1 (the scenario's bounds, SMARC's) is expected of the other controllers on the helix
            timing = run_metrics(scenario, extra, scratch / name.replace(" ", "_"), accept_exits=(0, 1))["timing"]
            rtf[name] = timing["realtime_factor"]
            breakdown[name] = timing["breakdown_us_per_step"]
            board_cpu[name] = timing["board_cpu_us_per_step"]
    with machine_floor(scratch / "cyclictest.json") as floor:
        paced = run_metrics(files["paced"], ["--px4-hitl", str(hitl)], scratch / "hitl",
                            accept_exits=(0, 1))["timing"]
    pacing = {"p99": paced["period_jitter_us"]["p99"], "max": paced["period_jitter_us"]["max"],
              "late": paced["late_steps"], "detail": paced["late_steps_detail"], "floor": floor}
    return {"rtf": rtf, "breakdown": breakdown, "board_cpu": board_cpu, "pacing": pacing}


def paced_scenario(hover: Path, quick: bool, scratch: Path) -> Path:
    """What the wall-clock row flies: hover.yaml, or with `quick` 3 s of PX4's HITL path on the ground (an outside
    pilot who never arms: PX4's preflight alone, ~12 s of wall clock, would be most of a smoke run). The pacing
    and the floor beside it are measured the same way over those 750 steps, so every figure is still printed."""
    if not quick:
        return hover
    path = scratch / "paced_quick.yaml"
    path.write_text(json.dumps({"name": "paced_quick", "duration_s": 3, "seed": 1, "pilot": {"type": "external"}}))
    return path


@contextmanager
def machine_floor(json_path: Path) -> Iterator[dict[str, Any]]:
    """cyclictest (Debian rt-tests) for as long as the block runs: a thread on each CPU at the bench's SCHED_FIFO
    priority, all waking every bench step, so the machine's own wake-up latency at the same moments as a paced run,
    on whichever CPU the bench runs (a VM's host takes its vCPUs away one at a time: one thread saw only its own).
    It leaves the CPUs' idle states as the bench finds them (--default-system; by default it would keep them out of
    deep idle while it runs, and the bench beside it with them). Fills in max_us (the worst over the CPUs), max_us
    per CPU, avg_us, cycles and the wake-ups later than FLOOR_STALL_US as (CLOCK_MONOTONIC s when it woke, latency
    us); nothing without cyclictest."""
    found: dict[str, Any] = {}
    exe = shutil.which("cyclictest")
    if exe is None:
        yield found
        return
    process = subprocess.Popen([exe, "--default-system", "--quiet", "--smp", "--distance=0",
                                f"--priority={FIFO_PRIORITY}", "--policy=fifo", f"--interval={STEP_US}",
                                f"--spike={FLOOR_STALL_US}",
                                f"--json={json_path}"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               preexec_fn=die_with_parent)  # noqa: PLW1509 - dies with the benchmark
    try:
        yield found
    finally:
        process.send_signal(signal.SIGINT)
        out, err = process.communicate(timeout=30)
    if process.returncode != 0 or not json_path.is_file():
        raise RuntimeError(f"cyclictest exited {process.returncode}: {err.strip()[-300:]}")
    threads = json.loads(json_path.read_text())["thread"].values()
    stalls = [(int(ts) * 1e-6, int(us)) for us, ts in re.findall(r"Spike:\s*(\d+):\s*TS:\s*(\d+)", out)]
    found.update(max_us=max(t["max"] for t in threads), max_us_per_cpu=[t["max"] for t in threads],
                 avg_us=statistics.mean(t["avg"] for t in threads), cycles=sum(t["cycles"] for t in threads),
                 stalls=stalls)


def floor_near(late: dict[str, Any], stalls: list[tuple[float, int]]) -> int:
    """The longest floor stall (us) overlapping the time a late step waited, widened by one step on each side:
    cyclictest wakes once a step, so a stall between two of its wake-ups shows only as far as it reaches the next."""
    behind_s, start_s = late["behind_ms"] * 1e-3, late["monotonic_s"]
    window = (start_s - behind_s - STEP_US * 1e-6, start_s + STEP_US * 1e-6)
    return max((us for woke_s, us in stalls if woke_s >= window[0] and woke_s - us * 1e-6 <= window[1]), default=0)


def builds(args: Any, scratch: Path) -> tuple[Px4Build, Path]:
    root = args.px4 or os.environ.get("HIL_PX4_DIR")
    if not root:
        raise Px4SetupError("give --px4 DIR or set HIL_PX4_DIR (a directory with PX4's builds or packages)")
    sitl = Px4Build.locate(find_build(Path(root), "sitl", scratch), "--px4")
    return sitl, find_build(Path(root), "hitl", scratch)


def first_run(gust: Path, scratch: Path, quick: bool) -> tuple[float, float]:
    """Wall-clock seconds of a whole gust run (start-up and shut-down included) with an empty flight-code cache,
    then of the same run again with what the first compiled. (--quick keeps the cache: compiling from nothing
    takes ~10 s and is tested in tests/test_compiled_flight_code.py.)"""
    env = None if quick else os.environ | {"XDG_CACHE_HOME": str(scratch / "empty-cache")}
    walls = []
    for name in ("first", "second"):
        start = time.perf_counter()
        run_metrics(gust, [], scratch / name, env=env)
        walls.append(time.perf_counter() - start)
    return walls[0], walls[1]


def print_table(rounds: list[dict[str, Any]], first_gust: tuple[float, float]) -> None:
    med = {name: statistics.median(r["rtf"][name] for r in rounds) for name in rounds[0]["rtf"]}
    ref = med["reference"]
    labels = {"reference": "PX4 v1.15.4 SITL + minimal simulator (reference)",
              "px4 hover": "hil run scenarios/hover.yaml --px4 DIR", "hover": "hil run scenarios/hover.yaml (emulator)",
              "gust": "hil run scenarios/gust.yaml (emulator)",
              "gust spin-wait": "  the same with --spin-wait (both ends poll)"}
    labels |= {f"helix {c}": f"scenarios/paper_helix.yaml 1 kHz, {c}" for c in CONTROLLERS}
    print(f"\nload average {os.getloadavg()[0]:.2f}; medians of {len(rounds)} round(s)")
    print(f"{'run':<52} {'real-time factor':>16} {'ratio':>7}  target")
    for name, label in labels.items():
        target = TARGETS.get(name.split(" ")[0] if name.startswith("helix") else name)
        goal = "" if target is None else (f">= {target:g}x real time" if name.startswith("helix")
                                          else f">= {target:g}")
        print(f"{label:<52} {med[name]:>15.1f}x {med[name] / ref:>7.2f}  {goal}")
        if name == "gust":
            print(f"  the whole run, start-up included: {first_gust[0]:.1f} s the first time on a machine (it compiles "
                  f"the flight code), {first_gust[1]:.1f} s after")
    pacing = [r["pacing"] for r in rounds]
    print(f"{'hil run scenarios/hover.yaml --px4-hitl DIR (250 Hz, wall clock)':<52} period error p99 "
          f"{statistics.median(p['p99'] for p in pacing):.0f} us (target <= {TARGETS['pacing p99']:g}), "
          f"max {max(p['max'] for p in pacing):.0f} us, late steps per run {[p['late'] for p in pacing]} (target 0)")
    for late in (d for p in pacing for d in p["detail"]):
        print(f"  late at {late['t_s']:.3f} s by {late['behind_ms']:.1f} ms; the step's longest part: "
              f"{late['longest_part']} {late['longest_part_ms']:.1f} ms")
    print_floor(pacing)


def print_floor(pacing: list[dict[str, Any]]) -> None:
    """Each round's HITL pacing beside cyclictest's in the same minute: the worst period error against the
    floor's worst wake-up + 1 ms, and each late step against the floor's stalls around it."""
    if not all(p["floor"] for p in pacing):
        print("  floor: cyclictest not found (Debian package rt-tests: `make bench-tools`); not measured")
        return
    print(f"  floor: cyclictest at SCHED_FIFO {FIFO_PRIORITY}, a thread on each CPU, every {STEP_US} us beside each "
          f"run; stalls are wake-ups over {FLOOR_STALL_US} us late on any CPU")
    for k, p in enumerate(pacing):
        floor = p["floor"]
        within = "yes" if p["max"] <= floor["max_us"] + 1000 else "no"
        outside = [d for d in p["detail"] if floor_near(d, floor["stalls"]) == 0]
        per_cpu = " / ".join(str(us) for us in floor["max_us_per_cpu"])
        print(f"  round {k + 1}: worst period error {p['max']:.0f} us, floor's worst {floor['max_us']} us "
              f"(per CPU {per_cpu}; avg {floor['avg_us']:.0f} us, {floor['cycles']} wake-ups, "
              f"{len(floor['stalls'])} stalls): "
              f"within floor + 1 ms: {within}; late steps {p['late']}, "
              f"{len(p['detail']) - len(outside)} of {len(p['detail'])} explained inside a floor stall")
        for d in outside:
            print(f"    late at {d['t_s']:.3f} s by {d['behind_ms']:.1f} ms with no floor stall around it")


def kernel_floor_us(steps: int) -> float:
    """The pty round trip with no Python on either end (benchmarks/pty_round_trip.c, built with gcc)."""
    with tempfile.TemporaryDirectory() as build:
        exe = Path(build) / "pty_round_trip"
        subprocess.run(["gcc", "-O2", "-o", str(exe), str(ROOT / "benchmarks" / "pty_round_trip.c")], check=True)
        return float(subprocess.run([str(exe), str(steps)], check=True, capture_output=True, text=True).stdout)


def python_floor_us(steps: int) -> float:
    """The same round trip between two minimal Python processes that sleep in `select`, as the bench and the
    emulator do: the Python floor, and on a machine whose idle CPUs halt, the cost of waking up twice."""
    pair = open_pty_pair()
    answer = ("import os, select, sys\nfd = os.open(sys.argv[1], os.O_RDWR | os.O_NOCTTY)\n"
              f"for _ in range({steps}):\n    got = 0\n    while got < 77:\n"
              "        select.select([fd], [], [])\n        got += len(os.read(fd, 65536))\n"
              "    os.write(fd, bytes(93))\n")
    child = subprocess.Popen([sys.executable, "-c", answer, pair.slave_path],
                             preexec_fn=die_with_parent)  # noqa: PLW1509 - dies with the benchmark
    fd = pair.master.fd
    start = time.perf_counter()
    for _ in range(steps):
        os.write(fd, bytes(77))
        got = 0
        while got < 93:
            select.select([fd], [], [])
            got += len(os.read(fd, 65536))
    elapsed = time.perf_counter() - start
    child.wait()
    pair.release_slave()
    pair.master.close()
    return elapsed / steps * 1e6


def print_breakdowns(rounds: list[dict[str, Any]], floor_us: float, python_us: float) -> None:
    print(f"\nfloor: a pty round trip between two C processes {floor_us:.1f} us, between two minimal Python "
          f"processes {python_us:.1f} us")
    print("where a bench step's time goes (us/step, median over rounds):")
    names = ("px4 hover", "gust", "helix smarc")
    print(f"  {'part':<24}" + "".join(f"{n:>14}" for n in names))
    for part in rounds[0]["breakdown"]["gust"]:
        row = [statistics.median(r["breakdown"][n][part] for r in rounds) for n in names]
        print(f"  {part:<24}" + "".join(f"{v:>14.1f}" for v in row))
    cpu = {n: statistics.median(r["board_cpu"][n] for r in rounds) for n in ("reference", *names)}
    print("the board's own CPU per step (us, all its threads; wait_for_board above is what a step waited for it):")
    print(f"  {'board CPU':<24}" + "".join(f"{cpu[n]:>14.1f}" for n in names)
          + f"   (PX4 in the reference: {cpu['reference']:.1f})")


def main() -> int:
    parser = benchmark_parser(__doc__)
    parser.add_argument("--px4", help="a directory with PX4 builds or packages (default: HIL_PX4_DIR)")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--power-save", action="store_true",
                        help="idle CPUs may sleep for every row (by default all rows run with them kept polling, as "
                             "hil run keeps them)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        scratch = Path(tmp)
        try:
            sitl, hitl = builds(args, scratch)
        except Px4SetupError as exc:
            print(f"loop_speed: {exc}", file=sys.stderr)
            return 2
        files = {name: scenario_file(name, args.quick, scratch) for name in ("hover", "gust")}
        files["helix"] = scenario_file("paper_helix", args.quick, scratch)
        files["paced"] = paced_scenario(files["hover"], args.quick, scratch)
        with idle_cpus_alike(args.power_save) as idle_note:
            print(f"idle CPUs for the reference and the lockstep rows: {idle_note}; for the paced row: halting, as "
                  "hil run leaves them in a paced run", flush=True)
            first_gust = first_run(files["gust"], scratch, args.quick)
        rounds = []
        for k in range(1 if args.quick else args.rounds):
            rounds.append(one_round(sitl, hitl, files, scratch / f"round{k}", args.quick, args.power_save))
            print(f"round {k + 1}: " + ", ".join(f"{n} {v:.1f}x" for n, v in rounds[-1]["rtf"].items()), flush=True)
        steps = 250 if args.quick else 5000
        with idle_cpus_alike(args.power_save):  # the floors of the lockstep rows' steps
            floors_us = kernel_floor_us(steps), python_floor_us(steps)
    print_table(rounds, first_gust)
    print_breakdowns(rounds, *floors_us)
    return 0


if __name__ == "__main__":
    sys.exit(main())
