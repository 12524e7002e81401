"""The bench's critical path in one compiled call: from the plant's true state after its step to the bytes of the
step's frames — the sensor models (their noise read from the blocks each model draws, so the noise of a seed is
the same), the fix's geodesy, and the setpoint, HIL_GPS, ODOMETRY and HIL_SENSOR frames with their checksums.

With sensor faults in the scenario the call is cut in two: the models, then the faults (Python, their own random
streams), then the frames.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from firmware_interface import actuator_reply, geodesy, hil_frames
from firmware_interface.compiled_code import CompiledCode
from firmware_interface.hil_frames import (
    HAS_GPS,
    ROW_PRESENT,
    ROW_SIZE,
    put_hil_gps,
    put_hil_sensor,
    put_odometry,
    put_setpoint,
)
from firmware_interface.link import frame_packing, frame_scan
from hil.sensors import Home, SensorsConfig, SensorSuite, suite
from hil.sensors.suite import sense_buffers

STEP = CompiledCode("bench-step", (Path(suite.__file__).parent, Path(__file__), Path(hil_frames.__file__),
                                   Path(frame_packing.__file__), Path(geodesy.__file__)))
FRAMES_MAX = 1024  # bytes: a setpoint, a fix, the true state and the sensors, whole
# what a step sends, beside the sensors: (has a setpoint, sends the true state as ODOMETRY, has sensor faults)
SETPOINT_FLAG, ODOMETRY_FLAG = 1, 2


@STEP.inline
def pack_step(row: np.ndarray, pos_ned: np.ndarray, vel_ned: np.ndarray, q_wxyz: np.ndarray, rates_frd: np.ndarray,
              flags: int, setpoint: np.ndarray, target: np.ndarray, frames: np.ndarray, ends: np.ndarray,
              link: np.ndarray) -> int:
    """The step's frames one after the other in `frames` (their ends in `ends`): the setpoint first when the board
    flies it this step, the fix when one is delivered, the true state for the emulator's exact-state path, then
    HIL_SENSOR, the frame a lockstep board answers. `link` = (first sequence number, system id, component id);
    returns how many."""
    seq, system_id, component_id, t_us = link[0], link[1], link[2], int(row[0])
    count, at = 0, 0
    if flags & SETPOINT_FLAG:
        at = put_setpoint(frames, at, seq + count, system_id, component_id, (t_us // 1000) & 0xFFFFFFFF,
                          (target[0], target[1]), setpoint[0:3], setpoint[3:6], setpoint[6:9], setpoint[9])
        ends[count], count = at, count + 1
    if int(row[ROW_PRESENT]) & HAS_GPS:
        at = put_hil_gps(frames, at, seq + count, system_id, component_id, row)
        ends[count], count = at, count + 1
    if flags & ODOMETRY_FLAG:
        at = put_odometry(frames, at, seq + count, system_id, component_id, t_us, pos_ned, vel_ned, q_wxyz, rates_frd)
        ends[count], count = at, count + 1
    ends[count] = put_hil_sensor(frames, at, seq + count, system_id, component_id, row)
    return count + 1


@STEP.compiled
def sense_and_pack(floats: np.ndarray, ints: np.ndarray, t_us: int, pos_ned: np.ndarray, vel_ned: np.ndarray,
                   q_wxyz: np.ndarray, rates_frd: np.ndarray, specific_force_frd: np.ndarray, row: np.ndarray,
                   flags: int, setpoint: np.ndarray, target: np.ndarray, frames: np.ndarray, ends: np.ndarray,
                   link: np.ndarray) -> int:
    """The sensor suite (`SensorSuite.buffers`: `floats`, `ints`) on the true state, then the step's frames."""
    sense_buffers(floats, ints, t_us, pos_ned, vel_ned, q_wxyz, rates_frd, specific_force_frd, row)
    return pack_step(row, pos_ned, vel_ned, q_wxyz, rates_frd, flags, setpoint, target, frames, ends, link)


@STEP.compiled
def sense_only(floats: np.ndarray, ints: np.ndarray, t_us: int, pos_ned: np.ndarray, vel_ned: np.ndarray,
               q_wxyz: np.ndarray, rates_frd: np.ndarray, specific_force_frd: np.ndarray, row: np.ndarray) -> None:
    sense_buffers(floats, ints, t_us, pos_ned, vel_ned, q_wxyz, rates_frd, specific_force_frd, row)


@STEP.compiled
def pack_only(row: np.ndarray, pos_ned: np.ndarray, vel_ned: np.ndarray, q_wxyz: np.ndarray, rates_frd: np.ndarray,
              flags: int, setpoint: np.ndarray, target: np.ndarray, frames: np.ndarray, ends: np.ndarray,
              link: np.ndarray) -> int:
    return pack_step(row, pos_ned, vel_ned, q_wxyz, rates_frd, flags, setpoint, target, frames, ends, link)


class StepFrames:
    """The buffers of the compiled step, allocated once per run."""

    def __init__(self, has_faults: bool) -> None:
        self.row = np.zeros(ROW_SIZE)
        self.setpoint = np.zeros(10)  # pos, vel, acc (NED, the board's local frame), yaw
        self.target = np.zeros(2, dtype=np.int64)
        self.frames = np.zeros(FRAMES_MAX, dtype=np.uint8)
        self.ends = np.zeros(4, dtype=np.int64)
        self.link = np.zeros(3, dtype=np.int64)
        self.has_faults = has_faults


def warm_up() -> None:
    """Compile (the first time on a machine) or load from the cache every compiled function of a step, with the
    argument types a flight gives them (`freeze` then forbids compiling more)."""
    suite = SensorSuite(SensorsConfig(), Home(), 250.0, np.random.default_rng(0))
    step = StepFrames(has_faults=False)
    vector, q = np.zeros(3), np.array((1.0, 0.0, 0.0, 0.0))
    suite.refill()
    sense_and_pack(*suite.buffers, 4000, vector, vector, q, vector, vector, step.row, SETPOINT_FLAG | ODOMETRY_FLAG,
                   step.setpoint, step.target, step.frames, step.ends, step.link)
    sense_only(*suite.buffers, 4000, vector, vector, q, vector, vector, step.row)
    pack_only(step.row, vector, vector, q, vector, 0, step.setpoint, step.target, step.frames, step.ends, step.link)
    for encode, fields in ((hil_frames.encode_hil_sensor, (step.row,)), (hil_frames.encode_hil_gps, (step.row,)),
                           (hil_frames.encode_setpoint, (0, 1, 1, vector, vector, vector, 0.0)),
                           (hil_frames.encode_odometry, (0, vector, vector, np.zeros(4), vector)),
                           (hil_frames.encode_hil_state_quaternion, (0, np.zeros(4), vector, vector, vector, vector,
                                                                     0.0))):
        encode(step.frames, 0, 1, 1, *fields)
    frame_scan.warm_up()  # the board's frames are read through it
    actuator_reply.warm_up()  # and its replies


def freeze() -> None:
    """No more compiling of a step's code: a type no flight gives is a bug, raised at once, not seconds of compiling
    in the middle of a run. Called on the thread that flies once `warm_up` has returned, not at its end beside the
    board's start: numba looks at a dispatcher's switch before at the signatures it holds, so the link's first read
    of the board (the scanner's compiled path), waiting for numba's lock while `warm_up` loaded that function, was
    refused once the freeze came in between ("compilation disabled", seen once in CI)."""
    STEP.freeze()
    hil_frames.FRAMES.freeze()
    frame_scan.FRAME_SCAN.freeze()
    actuator_reply.REPLY.freeze()


if __name__ == "__main__":  # `make fmu`: compiled into the cache at set-up, so that no run pays for it
    warm_up()
    print(f"bench step compiled in {STEP.cache_dir}")
