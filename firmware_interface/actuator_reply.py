"""A board's HIL_ACTUATOR_CONTROLS read by one compiled call: from the frame's bytes to the motor commands.

Why: in lockstep the board waits for the bench's next frames while the bench reads its reply, so every µs of that
read is on the step's critical path. Through the scanner, a message object and the clipping in Python it took
~4.5 µs alone (~1.6 now) and several times that inside a flight, every step. A read that is exactly one reply
(the lockstep case: the board writes its reply on its own) is now checked as the scanner checks a frame and read in
one call; any other read goes the scanner's way, and a reply found there is read by the same function, so one
definition says what a reply means (PX4's ranges: docs/px4_protocol.md §7).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from pymavlink.dialects.v20 import common

from firmware_interface.compiled_code import CompiledCode
from firmware_interface.hil_codec import ACTUATOR_FLAG_LOCKSTEP, MODE_FLAG_ARMED, ActuatorOutputs
from firmware_interface.link import frame_packing
from firmware_interface.link.frame_packing import (
    CRC_LEN,
    PAYLOAD,
    SIGNATURE_LEN,
    STX_V2,
    frame_end,
    get_f32,
    get_u64,
    payload_of,
)

REPLY = CompiledCode("actuator-reply", (Path(__file__), Path(frame_packing.__file__)))
MSGID, CRC_EXTRA, PAYLOAD_SIZE = (common.MAVLink_hil_actuator_controls_message.id,
                                  common.MAVLink_hil_actuator_controls_message.crc_extra,
                                  common.MAVLink_hil_actuator_controls_message.unpacker.size)
CONTROLS = 16
MAX_FRAME = PAYLOAD + PAYLOAD_SIZE + CRC_LEN + SIGNATURE_LEN  # bytes: a longer read is never one reply
# what `read_reply` writes into its `fields`
T_US, FLAGS, MODE, SYSTEM_ID = 0, 1, 2, 3


@REPLY.compiled
def read_reply(data: bytes, low: float, payload: np.ndarray, fields: np.ndarray, controls: np.ndarray) -> bool:
    """Whether `data` is one whole, valid HIL_ACTUATOR_CONTROLS frame (MAVLink 2, signed or not, or MAVLink 1;
    LEN within the payload and not 0, no unknown incompatibility flag, the X.25 checksum with CRC_EXTRA). If so,
    its time, flags, mode and sender into `fields` (uint64), and its controls into `controls` clipped to PX4's
    ranges: `low`..1 (0 for a motor, -1 for a reversible one), and 0 for a value that is not a number (a broken
    board). `payload`: room for the payload (PAYLOAD_SIZE bytes)."""
    if frame_end(data, 0, MSGID, CRC_EXTRA, PAYLOAD_SIZE) != len(data):
        return False
    payload_of(data, payload)
    fields[T_US] = get_u64(payload, 0)
    fields[FLAGS] = get_u64(payload, 8)
    fields[MODE] = payload[16 + 4 * CONTROLS]
    fields[SYSTEM_ID] = data[5] if data[0] == STX_V2 else data[3]
    for k in range(CONTROLS):
        value = get_f32(payload, 16 + 4 * k)
        controls[k] = (1.0 if value > 1.0 else max(value, low)) if math.isfinite(value) else 0.0
    return True


class ActuatorReader:
    """HIL_ACTUATOR_CONTROLS as the bench uses it: the first `motor_count` outputs drive the plant's rotors,
    as -1..1 when they are reversible."""

    def __init__(self, motor_count: int = 4, reversible: bool = False) -> None:
        self.motor_count = motor_count
        self.low = -1.0 if reversible else 0.0
        self.system_id = 0  # the sender of the last reply read
        self._payload = np.zeros(PAYLOAD_SIZE, dtype=np.uint8)
        self._fields = np.zeros(SYSTEM_ID + 1, dtype=np.uint64)
        self._controls = np.zeros(CONTROLS)

    def read(self, frame: bytes) -> ActuatorOutputs | None:
        """The outputs of `frame` when it is one whole, valid HIL_ACTUATOR_CONTROLS frame; None otherwise."""
        if len(frame) > MAX_FRAME or not read_reply(frame, self.low, self._payload, self._fields, self._controls):
            return None
        t_us, flags, mode, self.system_id = self._fields.tolist()
        motors = tuple(self._controls.tolist()[:self.motor_count])
        return ActuatorOutputs(t_us, motors, bool(mode & MODE_FLAG_ARMED),  # type: ignore[arg-type]
                               bool(flags & ACTUATOR_FLAG_LOCKSTEP), mode, flags)


def warm_up() -> None:
    """`read_reply` compiled (or loaded from its cache) now, not at a flight's first reply."""
    ActuatorReader().read(bytes(MAX_FRAME))
