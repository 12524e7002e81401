"""Real-time factor of `hil run scenarios/gust.yaml` (60 s simulated, lockstep, SMARC on the emulator)
and where each step's time goes, next to three floors: the kernel's pty round trip (C on both ends),
a ping-pong over the pty with a Python board that echoes one frame per HIL_SENSOR, and the whole
bench step with that echo board (no flight code)."""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from run_timing import benchmark_parser, scenario_file  # noqa: E402

from firmware_interface import hil_codec as codec  # noqa: E402
from firmware_interface.link import Link, open_pty_pair  # noqa: E402
from firmware_interface.link.encoder import FrameEncoder, message_class  # noqa: E402
from firmware_interface.link.transports import SerialTransport  # noqa: E402
from hil.sensors import Home, SensorsConfig, SensorSuite, TrueState  # noqa: E402
from plant_fmu import Plant  # noqa: E402

STEPS = 5000
QUICK_STEPS = 250  # 1 s simulated: GPS frames too


def echo_board(port: str) -> None:
    """Answers every HIL_SENSOR with one HIL_ACTUATOR_CONTROLS echoing its time: no flight code."""
    link = Link(SerialTransport(port))
    try:
        while True:
            for msg in link.receive(1.0):
                if msg.get_type() == "HIL_SENSOR":
                    link.send_fields("HIL_ACTUATOR_CONTROLS",
                                     codec.hil_actuator_controls_fields(msg.time_usec, (0.0,) * 4, False, True))
    except Exception:
        return


@contextmanager
def echo_link() -> Iterator[Link]:
    """The bench's end of a pty whose other end is the echo board, in its own process."""
    pair = open_pty_pair()
    proc = subprocess.Popen([sys.executable, __file__, "--echo", pair.slave_path])
    link = Link(pair.master)
    time.sleep(1.0)
    pair.release_slave()
    try:
        yield link
    finally:
        link.close()
        proc.wait(5)


def wait_reply(link: Link, t_us: int) -> None:
    while True:
        for msg in link.receive(1.0):
            if msg.get_type() == "HIL_ACTUATOR_CONTROLS" and msg.time_usec >= t_us:
                return


def kernel_floor(steps: int) -> float:
    """The pty round trip with no Python on either end (benchmarks/pty_round_trip.c, built with gcc)."""
    with tempfile.TemporaryDirectory() as build:
        exe = Path(build) / "pty_round_trip"
        subprocess.run(["gcc", "-O2", "-o", str(exe), str(ROOT / "benchmarks" / "pty_round_trip.c")], check=True)
        result = subprocess.run([str(exe), str(steps)], check=True, capture_output=True, text=True)
        return float(result.stdout) * 1e-6


def ping_pong_floor(steps: int) -> float:
    encoder = FrameEncoder(1, 51)
    with echo_link() as link:
        start = time.perf_counter()
        for k in range(1, steps + 1):
            link.send_frame(encoder.encode(message_class("HIL_SENSOR"), codec.hil_sensor_fields(
                codec.SensorReadings(4000 * k, (0.0, 0.0, -9.8), (0.0, 0.0, 0.0)))))
            wait_reply(link, 4000 * k)
        return (time.perf_counter() - start) / steps


def bench_step_floor(steps: int) -> float:
    """Plant + sensors + codec + pty round trip to the echo board, per step."""
    encoder = FrameEncoder(1, 51)
    suite = SensorSuite(SensorsConfig(), Home(), 250.0, np.random.default_rng(0))
    with echo_link() as link, Plant({"init_pos_d": -10.0}) as plant:
        o = plant.output_index
        pos, vel = [o[n] for n in ("pos_n", "pos_e", "pos_d")], [o[n] for n in ("vel_n", "vel_e", "vel_d")]
        quat, rates = [o[n] for n in ("q_w", "q_x", "q_y", "q_z")], [o[n] for n in ("rate_x", "rate_y", "rate_z")]
        force = [o[n] for n in ("specific_force_x", "specific_force_y", "specific_force_z")]
        u = np.zeros(len(plant.INPUT_NAMES))
        start = time.perf_counter()
        for k in range(1, steps + 1):
            plant.set_inputs(u)
            out = plant.step(0.004)
            readings, gps = suite.step(TrueState(4000 * k, out[pos], out[vel], out[quat], out[rates], out[force]))
            if gps is not None:
                link.send_frame(encoder.encode(message_class("HIL_GPS"), codec.hil_gps_fields(gps)))
            link.send_frame(encoder.encode(message_class("HIL_SENSOR"), codec.hil_sensor_fields(readings)))
            wait_reply(link, 4000 * k)
        return (time.perf_counter() - start) / steps


def full_run(quick: bool) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        gust, runs = scenario_file("gust", quick, Path(tmp)), Path(tmp) / "runs"
        subprocess.run([sys.executable, "-m", "hil.cli", "run", "--no-report", str(gust), "--runs", str(runs)],
                       check=True, capture_output=True, cwd=ROOT)
        run_dir = next(runs.iterdir())
        return json.loads((run_dir / "metrics.json").read_text())["timing"]


def main() -> None:
    args = benchmark_parser(__doc__).parse_args()
    steps = QUICK_STEPS if args.quick else STEPS
    floors = {"kernel pty round trip (C on both ends)": kernel_floor(steps),
              "pty ping-pong with a Python echo board": ping_pong_floor(steps),
              "bench step (plant, sensors, codec) + echo": bench_step_floor(steps)}
    timing = full_run(args.quick)
    print("loop speed, 250 Hz bench steps (4 ms of simulated time each)")
    for label, seconds in floors.items():
        print(f"  floor: {label:42s} {seconds * 1e6:6.1f} us/step -> {0.004 / seconds:6.1f}x real time")
    print(f"  gust.yaml, SMARC on the emulator: {timing['sim_s']:.1f} s simulated in {timing['wall_s']:.1f} s "
          f"-> {timing['realtime_factor']:.2f}x real time")
    print(f"  sensor -> actuator round trip: p50 {timing['round_trip_us']['p50']:.0f} us, "
          f"p99 {timing['round_trip_us']['p99']:.0f} us")
    print("  where a step's time goes (us/step):")
    for part, us in timing["breakdown_us_per_step"].items():
        print(f"    {part:20s} {us:7.1f}")


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "--echo":
        echo_board(sys.argv[2])
    else:
        main()
