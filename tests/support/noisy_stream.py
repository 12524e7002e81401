"""A MAVLink byte stream with known, injected faults (for scanner tests and the link benchmark).

Valid frames are packed by pymavlink itself (the oracle). So that every fault has exactly
one outcome, no byte after a frame's STX is 0xFD/0xFE, and garbage holds neither.
"""

from __future__ import annotations

import random
from collections import Counter
from dataclasses import dataclass, field

from pymavlink.dialects.v20 import common

START_BYTES = (0xFD, 0xFE)


def _random_message(rng: random.Random) -> common.MAVLink_message:
    f = lambda: rng.uniform(-50, 50)  # noqa: E731
    choice = rng.randrange(6)
    if choice == 0:
        return common.MAVLink_hil_sensor_message(rng.getrandbits(40), *(f() for _ in range(13)), 0x1BFF, 0)
    if choice == 1:
        return common.MAVLink_hil_gps_message(rng.getrandbits(40), 3, rng.randint(-900000000, 900000000),
                                              rng.randint(-1800000000, 1800000000), rng.randint(0, 10**6),
                                              rng.randint(0, 500), rng.randint(0, 500), rng.randint(0, 2000),
                                              rng.randint(-2000, 2000), rng.randint(-2000, 2000),
                                              rng.randint(-2000, 2000), rng.randint(0, 35999), 10, 0, 0)
    if choice == 2:
        return common.MAVLink_hil_actuator_controls_message(rng.getrandbits(40), [rng.random() for _ in range(16)],
                                                            129, 1)
    if choice == 3:
        return common.MAVLink_hil_state_quaternion_message(rng.getrandbits(40), [rng.random() for _ in range(4)],
                                                           f(), f(), f(), 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11)
    if choice == 4:
        return common.MAVLink_heartbeat_message(2, 12, 129 + 32, 0, 4, 3)
    return common.MAVLink_command_long_message(1, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0)


def clean_frame(rng: random.Random, mav: common.MAVLink) -> bytes:
    while True:
        frame = bytes(_random_message(rng).pack(mav))
        mav.seq = (mav.seq + 1) % 256
        if not any(b in START_BYTES for b in frame[1:]):
            return frame


def garbage(rng: random.Random, n: int) -> bytes:
    return bytes(rng.choice([b for b in range(256) if b not in START_BYTES]) for _ in range(n))


@dataclass
class NoisyStream:
    data: bytes
    frames: list[bytes]  # the frames no fault touched, in order
    injected: Counter[str] = field(default_factory=Counter)


def make_noisy_stream(n_frames: int, seed: int, fault_rate: float = 0.3) -> NoisyStream:
    """Valid frames interleaved with garbage, fake starts (large LEN, unknown id, bad flags),
    frames truncated after their header, and frames with a flipped bit after the header."""
    rng = random.Random(seed)
    mav = common.MAVLink(None, srcSystem=1, srcComponent=1)
    out = bytearray()
    intact: list[bytes] = []
    injected: Counter[str] = Counter()
    for _ in range(n_frames):
        frame = clean_frame(rng, mav)
        if rng.random() >= fault_rate:
            out += frame
            intact.append(frame)
            continue
        fault = rng.randrange(6)
        if fault == 0:
            n = rng.randint(1, 40)
            out += garbage(rng, n)
            injected["garbage_bytes"] += n
            out += frame
            intact.append(frame)
        elif fault == 1:  # a HEARTBEAT header claiming LEN 255 (full payload is 9)
            out += bytes([0xFD, 0xFF, 0, 0, 0, 1, 1, 0, 0, 0]) + frame
            injected["bad_length"] += 1
            injected["garbage_bytes"] += 9
            intact.append(frame)
        elif fault == 2:  # a header naming a message id that does not exist
            out += bytes([0xFD, 9, 0, 0, 0, 1, 1, 0x55, 0x55, 0x55]) + frame
            injected["unknown_id"] += 1
            injected["garbage_bytes"] += 9
            intact.append(frame)
        elif fault == 3:  # unknown incompat flag bit
            out += bytes([0xFD, 9, 0x04, 0, 0, 1, 1, 0, 0, 0]) + frame
            injected["bad_flags"] += 1
            injected["garbage_bytes"] += 9
            intact.append(frame)
        elif fault == 4:  # cut after the header, before the CRC
            cut = rng.randint(10, len(frame) - 3)
            out += frame[:cut]
            injected["bad_crc"] += 1
            injected["garbage_bytes"] += cut - 1
        else:  # one flipped bit after the header (never creating a start byte)
            corrupted = bytearray(frame)
            while True:
                i = rng.randrange(10, len(frame))
                flipped = corrupted[i] ^ (1 << rng.randrange(8))
                if flipped not in START_BYTES:
                    corrupted[i] = flipped
                    break
            out += corrupted
            injected["bad_crc"] += 1
            injected["garbage_bytes"] += len(frame) - 1
    return NoisyStream(bytes(out), intact, injected)
