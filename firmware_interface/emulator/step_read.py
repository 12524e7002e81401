"""A lockstep step's read, as the bench writes it, checked and taken apart in one compiled call.

Why: the bench writes each step's frames in one piece (its setpoint, the true state's ODOMETRY when the emulator
flies on it, then HIL_SENSOR) and waits for the reply, so everything the emulator does from that read to its reply
is on the step's critical path. The scanner, a message object per frame and the dispatch on the message's name cost
~10 µs a step in a flight: more than the estimator's sample. A read that is exactly a whole, valid HIL_SENSOR frame
after at most one SET_POSITION_TARGET_LOCAL_NED and one ODOMETRY, in that order, is checked here as the scanner
checks a frame (`frame_packing.frame_end`) and the setpoint's fields are read out; any other read goes the
scanner's way, to the same handlers.
"""

from __future__ import annotations

import numpy as np
from pymavlink.dialects.v20 import common

from firmware_interface.emulator.compiled import flight_code
from firmware_interface.link.frame_packing import frame_end, get_f32, get_u32, message_layout, payload_of

SETPOINT_ID, SETPOINT_CRC_EXTRA, SETPOINT_SIZE = message_layout(common.MAVLink_set_position_target_local_ned_message)
SENSOR_ID, SENSOR_CRC_EXTRA, SENSOR_SIZE = message_layout(common.MAVLink_hil_sensor_message)
TRUTH_ID, TRUTH_CRC_EXTRA, TRUTH_SIZE = message_layout(common.MAVLink_odometry_message)
# what a step's read holds besides its HIL_SENSOR (`read_step`'s answer); its frames end at `ends[:3]`, in this order
SETPOINT, TRUTH = 1, 2
# SET_POSITION_TARGET_LOCAL_NED's fields in `read_step`'s output: in wire order, as floats (the integers exactly)
SETPOINT_FIELD_NAMES = tuple(common.MAVLink_set_position_target_local_ned_message.ordered_fieldnames)
TIME_BOOT_MS, X, VX, AFX, YAW, TYPE_MASK, TARGET_SYSTEM, TARGET_COMPONENT, COORDINATE_FRAME = (
    SETPOINT_FIELD_NAMES.index(name) for name in ("time_boot_ms", "x", "vx", "afx", "yaw", "type_mask",
                                                   "target_system", "target_component", "coordinate_frame"))
SETPOINT_FIELDS = len(SETPOINT_FIELD_NAMES)


@flight_code
def read_step(data: bytes, payload: np.ndarray, setpoint: np.ndarray, ends: np.ndarray) -> int:
    """When `data` is exactly a whole, valid HIL_SENSOR frame after at most one whole, valid
    SET_POSITION_TARGET_LOCAL_NED and one ODOMETRY, in that order: which of the two it holds (SETPOINT | TRUTH), the
    ends of the setpoint, the ODOMETRY and the HIL_SENSOR into `ends` (a frame it lacks ends where the one before it
    does), and the setpoint's fields into `setpoint`. -1 for any other read. `payload`: room for the setpoint's
    payload (SETPOINT_SIZE bytes)."""
    setpoint_end = max(frame_end(data, 0, SETPOINT_ID, SETPOINT_CRC_EXTRA, SETPOINT_SIZE), 0)
    truth_end = max(frame_end(data, setpoint_end, TRUTH_ID, TRUTH_CRC_EXTRA, TRUTH_SIZE), setpoint_end)
    if frame_end(data, truth_end, SENSOR_ID, SENSOR_CRC_EXTRA, SENSOR_SIZE) != len(data):
        return -1
    ends[0], ends[1], ends[2] = setpoint_end, truth_end, len(data)
    if setpoint_end > 0:
        payload_of(data, payload)
        setpoint[TIME_BOOT_MS] = get_u32(payload, 0)
        for k in range(X, TYPE_MASK):  # x .. yaw_rate
            setpoint[k] = get_f32(payload, 4 * k)
        setpoint[TYPE_MASK] = int(payload[48]) | int(payload[49]) << 8
        setpoint[TARGET_SYSTEM] = payload[50]
        setpoint[TARGET_COMPONENT] = payload[51]
        setpoint[COORDINATE_FRAME] = payload[52]
    return (SETPOINT if setpoint_end > 0 else 0) | (TRUTH if truth_end > setpoint_end else 0)


class StepReader:
    """`read_step` with its buffers."""

    def __init__(self) -> None:
        self.setpoint = np.zeros(SETPOINT_FIELDS)
        self.ends = np.zeros(3, dtype=np.int64)
        self._payload = np.zeros(SETPOINT_SIZE, dtype=np.uint8)

    def read(self, data: bytes) -> int:
        """`read_step`'s answer for `data`; the frames' ends in `ends`, a setpoint's fields in `setpoint`."""
        return read_step(data, self._payload, self.setpoint, self.ends)


def warm_up() -> None:
    """`read_step` compiled (or loaded from its cache) now, not at a flight's first step."""
    StepReader().read(bytes(SETPOINT_SIZE))
