"""Every script in benchmarks/ runs once with --quick and prints its figures, so that a benchmark broken by a
change of the code it measures fails here rather than the next time someone measures with it."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from tests.support.px4_builds import px4_root

pytestmark = [pytest.mark.slow, pytest.mark.e2e]
ROOT = Path(__file__).resolve().parent.parent
HELPERS = {"run_timing"}  # shared by the benchmarks, not one itself
TIMEOUT_S = 300  # a quick run takes seconds to a minute; a hung one fails its test

# per script, text of each figure line it prints (the numbers in them vary from run to run)
FIGURES: dict[str, tuple[str, ...]] = {
    "emulator_step": ("HIL_SENSOR in -> HIL_ACTUATOR_CONTROLS out", "smarc ", "smpid ", "backstepping ",
                      "in-process", "us (median; AUTO.TAKEOFF", "pty round trip p50", "p99",
                      "reads replayed in process (replies byte for byte as in the flight: yes)",
                      "the emulator's CPU in that flight"),
    "foxglove_speed": ("round 1: --foxglove", "messages to the client", "medians of 1 rounds",
                       "--foxglove with a client on every channel", "x real time, without", ": ratio"),
    "gcs_relay_speed": ("round 1: relay on", "datagrams reached the GCS", "medians of 1 rounds",
                        "x real time, --no-gcs", ": ratio"),
    "link_scan": ("noisy stream:", "faults injected", "frames recovered   ours:", "pymavlink robust parser",
                  "scan+decode, clean stream", "scan+decode, noisy stream", "us/frame",
                  "encode HIL_SENSOR (codec + frame)"),
    "loop_speed": ("round 1: reference", "PX4 v1.15.4 SITL + minimal simulator (reference)",
                   "hil run scenarios/hover.yaml --px4 DIR", "hil run scenarios/hover.yaml (emulator)",
                   "hil run scenarios/gust.yaml (emulator)", "the same with --spin-wait (both ends poll)",
                   "scenarios/paper_helix.yaml 1 kHz, smarc",
                   "1 kHz, smpid", "1 kHz, backstepping", "--px4-hitl DIR (250 Hz, wall clock) period error p99",
                   "late steps per run", "  floor: cyclictest", "floor: a pty round trip",
                   "where a bench step's time goes", "wait_for_board",
                   "the board's own CPU per step", "PX4 in the reference:"),
    "memory_long_run": ("timing:", "real-time factor", "bench RSS:", "MB at start", "MB at most", "MB at the end",
                        "growth after the first", "(target ≤ 20 MB)"),
    "plant_step": ("plant_fmu.Plant, no rotor aerodynamics", "plant_fmu.Plant, inspection quad's aero",
                   "fmpy FMU2Slave (lists), no aerodynamics", "us/step"),
    "px4_sitl_speed": ("round 1: PX4 + minimal simulator", "hil run hover --px4", "real-time factor",
                       "SITL + minimal simulator", "hil run scenarios/hover.yaml --px4 DIR",
                       "bench per step (us, median over rounds):", "wait_for_board", "PX4's own CPU per step"),
    "sensors": ("sensor suite, 250 Hz bench", "ideal", "px4_sitl", "paper parts (mpu6050, m8n, ms5611)", "us/step"),
    "stream_cycle": ("round 1:", "x real time, a cycle's step", "steps a cycle",
                     "by its place in the board's stream cycle", "place 0:", "us (median step)",
                     "the lighter half of its places", "x as fast"),
    "sweep_throughput": ("round 1: 1 worker", "samples/min", "samples per sweep, medians of 1 rounds",
                         "2 workers", ": ratio", "bare runs 2 vs 1", "machine ceiling (two bare hil runs"),
    "telemetry_load": ("telemetry load, scenarios/hover.yaml on the emulator", "no subscriber",
                       "a subscriber taking every sample", "a subscriber sleeping 50 ms per sample", "x real time",
                       "samples; ratio to none", "samples; ratio to the prompt one"),
}
NEEDS_PX4 = {"px4_sitl_speed", "loop_speed"}


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.px4) if n in NEEDS_PX4 else n for n in FIGURES])
def test_benchmark_runs_quick_and_prints_its_figures(name: str) -> None:
    if name in NEEDS_PX4:
        px4_root()  # unset HIL_PX4_DIR skips with the PX4 tests' line; set, the script reads it itself
    result = subprocess.run([sys.executable, f"benchmarks/{name}.py", "--quick"], cwd=ROOT, capture_output=True,
                            text=True, timeout=TIMEOUT_S)
    assert result.returncode == 0, f"exit {result.returncode}\n{result.stdout}\n{result.stderr[-3000:]}"
    missing = [text for text in FIGURES[name] if text not in result.stdout]
    assert not missing, f"missing {missing} in:\n{result.stdout}"


def test_every_benchmark_has_a_smoke_run() -> None:
    scripts = {p.stem for p in (ROOT / "benchmarks").glob("*.py")} - HELPERS
    assert scripts == set(FIGURES)
