"""µs from HIL_SENSOR in to HIL_ACTUATOR_CONTROLS out, per controller, with the estimator.

1. In-process: the emulated board handles a HIL_SENSOR frame (decode, estimator, controller,
   mixer, encode of the reply), armed and flying on px4_sitl-like sensor packets: holding position (POSCTL,
   the step the bench's own offboard flight costs the same) and in AUTO.TAKEOFF (the navigator's reference
   sampled every step, its decisions at 20 Hz, the ground-station streams); and flying on the true state
   (`state_source: truth`, the paper's studies): the step's ODOMETRY frame, then its HIL_SENSOR.
2. Round trip over a real pty to the emulator in its own process (what the bench waits for).
3. A `gust.yaml` flight (`hil run`), then its reads replayed into an emulator in this process
   (`firmware_interface/emulator/replay.py`): a real flight's mix of steps (the 50 Hz streams, the navigator's
   ticks, GPS) handled without the pty, against the CPU the emulator's process used a step in that flight.
"""

from __future__ import annotations

import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from pymavlink.dialects.v20 import common
from run_timing import benchmark_parser, run_metrics, scenario_file

from firmware_interface import hil_codec as codec
from firmware_interface import hil_frames
from firmware_interface.board import SIMULATED, BoardSession
from firmware_interface.board_waits import arm
from firmware_interface.emulator import EmulatedBoard, build_config
from firmware_interface.emulator.replay import replay_run
from firmware_interface.link import Link, Message, open_pty_pair
from firmware_interface.link.dialect import frame_msgid
from firmware_interface.link.light_messages import LIGHT
from firmware_interface.link.transports import UdpTransport
from firmware_interface.px4_modes import FlightMode
from hil.host.lifetime import die_with_parent
from hil.sensors import Home, SensorsConfig, SensorSuite, TrueState

G = 9.80665
CONTROLLERS = ("smarc", "smpid", "backstepping")
SETTLE = 750  # 3 s: the estimator settles, then the board is armed and flies on every sample
FRAMES, QUICK_FRAMES = 3000, SETTLE + 50


def odometry_frames(n: int) -> list[bytes]:
    """The true state at rest, tilted a little (every Euler angle non-zero), one ODOMETRY frame a step."""
    buffer = np.zeros(512, dtype=np.uint8)
    q_wxyz = np.array([0.9990482, 0.0261769, 0.0174524, 0.0261769])
    return [buffer[:hil_frames.encode_odometry(buffer, k % 256, 1, 51, 4000 * (k + 1), np.array([0.1, 0.2, -3.0]),
                                               np.zeros(3), q_wxyz, np.zeros(3))].tobytes() for k in range(n)]


def sensor_frames(n: int) -> list[tuple[bytes, bytes | None]]:
    suite = SensorSuite(SensorsConfig(), Home(), 250.0, np.random.default_rng(0))
    buffer = np.zeros(512, dtype=np.uint8)
    frames = []
    for k in range(n):
        truth = TrueState(4000 * (k + 1), np.zeros(3), np.zeros(3), np.array([1.0, 0, 0, 0]), np.zeros(3),
                          np.array([0.0, 0.0, -G]))
        row = codec.sensor_row(*suite.step(truth))
        gps_frame = None
        if int(row[hil_frames.ROW_PRESENT]) & hil_frames.HAS_GPS:
            gps_frame = buffer[:hil_frames.encode_hil_gps(buffer, 2 * k, 1, 51, row)].tobytes()
        frames.append((buffer[:hil_frames.encode_hil_sensor(buffer, 2 * k + 1, 1, 51, row)].tobytes(), gps_frame))
    return frames


def light_message(frame: bytes) -> Message:
    """A frame as the emulator's link hands it over (`Link._decode`: no pymavlink object)."""
    return LIGHT[frame_msgid(frame)](frame)


def in_process(controller: str, frames: list[tuple[bytes, bytes | None]],
               mode: FlightMode = FlightMode.POSCTL, truth: list[bytes] | None = None) -> float:
    """The median µs of a step's frames handled (with `truth`: its ODOMETRY frame, then its HIL_SENSOR), decoded
    as the emulator's link decodes them."""
    sink = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sink.bind(("127.0.0.1", 0))  # never read: the replies are dropped when its buffer fills
    board = EmulatedBoard(Link(UdpTransport("127.0.0.1", sink.getsockname()[1], listen=False)),
                          build_config({"controller": controller, "state_source": "truth" if truth else "estimator"}))
    decoder = common.MAVLink(None)
    times: list[float] = []
    for k, (sensor, gps) in enumerate(frames):
        if gps:
            board.handle(decoder.decode(bytearray(gps)))
        if k == SETTLE:
            board.commander.mode = mode  # arming in it flies it
            assert board.commander.arm() == 0
        start = time.perf_counter()
        if truth:
            board.handle(light_message(truth[k]))
        board.handle(light_message(sensor))
        if k > SETTLE:
            times.append(time.perf_counter() - start)
    sink.close()
    return statistics.median(times) * 1e6


def round_trip(controller: str, frames: list[tuple[bytes, bytes | None]]) -> tuple[float, float]:
    pair = open_pty_pair()
    proc = subprocess.Popen([sys.executable, "-m", "firmware_interface.emulator", "--port", pair.slave_path,
                             "--controller", controller],
                            preexec_fn=die_with_parent)  # noqa: PLW1509 - dies with the benchmark
    session = BoardSession(Link(pair.master), SIMULATED, watchdog_s=2.0)
    session.wait_heartbeat(10.0)
    pair.release_slave()
    times: list[float] = []
    for k, (sensor, gps) in enumerate(frames):
        if gps:
            session.link.send_frame(gps)
        if k == SETTLE:
            arm(session, True, timeout_s=3.0)
        session._awaited_t_us = 4000 * (k + 1)
        start = time.perf_counter()
        session.link.send_frame(sensor)
        while session._awaited_t_us is not None:
            session.poll(1.0)
        if k > SETTLE:
            times.append(time.perf_counter() - start)
    proc.terminate()
    proc.wait(5)
    session.link.close()
    times.sort()
    return statistics.median(times) * 1e6, times[int(0.99 * len(times))] * 1e6


def replayed_flight(quick: bool) -> None:
    with tempfile.TemporaryDirectory() as scratch:
        runs = Path(scratch) / "runs"
        metrics = run_metrics(scenario_file("gust", quick, Path(scratch)), ["--no-gcs"], runs)
        replays = [replay_run(next(runs.iterdir())) for _ in range(3)]
    handling_us = np.concatenate([r.handling_s[r.handling_s.size // 4:] for r in replays]) * 1e6  # compiled by then
    same = all(r.first_difference is None for r in replays)
    print(f"  a gust flight's {replays[0].reads} reads replayed in process (replies byte for byte as in the flight: "
          f"{'yes' if same else 'NO'}): p50 {np.median(handling_us):.1f} us, mean {handling_us.mean():.1f} us a read; "
          f"the emulator's CPU in that flight {metrics['timing']['board_cpu_us_per_step']:.1f} us a step")


def main() -> None:
    args = benchmark_parser(__doc__).parse_args()
    frames = sensor_frames(QUICK_FRAMES if args.quick else FRAMES)
    truth = odometry_frames(len(frames))
    print("emulator: HIL_SENSOR in -> HIL_ACTUATOR_CONTROLS out, estimator on px4_sitl-like packets, armed")
    for controller in CONTROLLERS:
        step_us = in_process(controller, frames)
        navigator_us = in_process(controller, frames, FlightMode.AUTO_TAKEOFF)
        truth_us = in_process(controller, frames, truth=truth)
        p50, p99 = round_trip(controller, frames)
        print(f"  {controller:12s}  in-process {step_us:6.1f} us (median; AUTO.TAKEOFF {navigator_us:6.1f} us; "
              f"on the true state {truth_us:6.1f} us)   pty round trip p50 {p50:6.1f} us  p99 {p99:6.1f} us")
    replayed_flight(args.quick)


if __name__ == "__main__":
    main()
