"""Frames recovered from one noisy stream by our scanner vs pymavlink's robust parser,
and the cost per frame of scanning+decoding and of encoding a HIL_SENSOR frame."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
from pymavlink.dialects.v20 import common

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from run_timing import benchmark_parser

from firmware_interface import hil_codec as codec
from firmware_interface import hil_frames
from firmware_interface.link import FrameScanner, frame_scan
from tests.support.noisy_stream import make_noisy_stream

N_FRAMES, QUICK_FRAMES = 5000, 200
N_ENCODES, QUICK_ENCODES = 20000, 200


def ours(data: bytes) -> tuple[int, float]:
    scanner = FrameScanner()
    decoder = common.MAVLink(None)
    start = time.perf_counter()
    messages = [decoder.decode(bytearray(f)) for f in scanner.feed(data, 0.0)]
    return len(messages), time.perf_counter() - start


def pymavlink_robust(data: bytes) -> tuple[int, float]:
    mav = common.MAVLink(None)
    mav.robust_parsing = True
    start = time.perf_counter()
    good = 0
    for i in range(0, len(data), 64):  # as a serial read loop would hand it over
        for msg in mav.parse_buffer(data[i : i + 64]) or []:
            good += msg.get_type() != "BAD_DATA" and not msg.get_type().startswith("UNKNOWN")
    while (msg := mav.parse_char(b"")) is not None:
        good += msg.get_type() != "BAD_DATA" and not msg.get_type().startswith("UNKNOWN")
    return good, time.perf_counter() - start


def encode_costs(n: int) -> tuple[float, float]:
    """µs per HIL_SENSOR frame from a step's readings: ours (the compiled packer on the readings' row, as the
    bench's step packs it) against pymavlink's pack() of the same fields."""
    readings = codec.SensorReadings(4000, (0.1, -0.2, -9.81), (0.01, 0.02, 0.03), (2e-5, 1e-6, 4e-5),
                                    codec.Baro(95540.0, 11.8, 488.0))
    row, buffer = codec.sensor_row(readings), np.zeros(512, dtype=np.uint8)
    hil_frames.encode_hil_sensor(buffer, 0, 1, 51, row)  # compiled (or loaded) before the clock starts
    start = time.perf_counter()
    for k in range(n):
        buffer[:hil_frames.encode_hil_sensor(buffer, k & 0xFF, 1, 51, row)].tobytes()
    ours_us = (time.perf_counter() - start) / n * 1e6
    mav = common.MAVLink(None, srcSystem=1, srcComponent=51)
    fields = common.MAVLink_hil_sensor_message.unpacker.unpack(bytes(buffer[10:75]))  # the frame's own fields
    start = time.perf_counter()
    for _ in range(n):
        common.MAVLink_hil_sensor_message(*fields).pack(mav)
    return ours_us, (time.perf_counter() - start) / n * 1e6


def main() -> None:
    args = benchmark_parser(__doc__).parse_args()
    frame_scan.warm_up()  # the scanner's compiled path loaded (or compiled) before any clock starts, as a run does
    n_frames = QUICK_FRAMES if args.quick else N_FRAMES
    clean = make_noisy_stream(n_frames, seed=5, fault_rate=0.0)
    noisy = make_noisy_stream(n_frames, seed=5, fault_rate=0.3)
    print(f"noisy stream: {len(noisy.data)} bytes, {len(noisy.frames)} intact frames, "
          f"faults injected: {dict(noisy.injected)}")
    n_ours, t_ours = ours(noisy.data)
    n_py, t_py = pymavlink_robust(noisy.data)
    print(f"  frames recovered   ours: {n_ours:5d}   pymavlink robust parser: {n_py:5d}"
          f"   (intact: {len(noisy.frames)})")
    _, t_clean_ours = ours(clean.data)
    _, t_clean_py = pymavlink_robust(clean.data)
    print(f"  scan+decode, clean stream  ours: {t_clean_ours / len(clean.frames) * 1e6:5.1f} us/frame"
          f"   pymavlink: {t_clean_py / len(clean.frames) * 1e6:5.1f} us/frame")
    print(f"  scan+decode, noisy stream  ours: {t_ours / max(n_ours, 1) * 1e6:5.1f} us/frame"
          f"   pymavlink: {t_py / max(n_py, 1) * 1e6:5.1f} us/frame")
    ours_us, py_us = encode_costs(QUICK_ENCODES if args.quick else N_ENCODES)
    print(f"  encode HIL_SENSOR (codec + frame)  ours: {ours_us:5.1f} us   pymavlink: {py_us:5.1f} us")


if __name__ == "__main__":
    main()
