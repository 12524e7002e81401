"""MAVLink 2 frames written field by field into a byte buffer, by compiled code (or by Python, the same code).

A frame starts at `at`: the 10-byte header, the payload from `at + PAYLOAD`, then the X.25 checksum (CRC-16/
MCRF4XX over the header after the magic byte, the payload and the message's CRC_EXTRA). A packer writes every
field of its payload at its wire offset (pymavlink's field order: by size, then as declared), then `finish_frame`
trims the payload's trailing zero bytes, as MAVLink 2 does, and writes the header and the checksum. The frames
equal pymavlink's `pack()`, byte for byte (tests/test_hil_codec.py).
"""

from __future__ import annotations

import numpy as np

from firmware_interface.compiled_code import CompiledCode

STX_V2, STX_V1 = 0xFD, 0xFE
PAYLOAD = 10  # header bytes before the payload
PAYLOAD_V1 = 6  # the same in a MAVLink 1 frame
OVERHEAD = 12  # header and checksum
CRC_LEN, SIGNATURE_LEN = 2, 13
INCOMPAT_SIGNED = 0x01  # the one incompatibility flag MAVLink 2 defines
inline = CompiledCode.inline


def message_layout(message: type) -> tuple[int, int, int]:
    """(msgid, CRC_EXTRA, payload bytes before trimming) of a pymavlink message class: what a packer needs."""
    return message.id, message.crc_extra, message.unpacker.size  # type: ignore[attr-defined]


@inline
def put_u8(buf: np.ndarray, at: int, value: int) -> None:
    buf[at] = value & 0xFF


@inline
def put_u16(buf: np.ndarray, at: int, value: int) -> None:
    """Also an int16 in two's complement: the low 16 bits either way."""
    buf[at] = value & 0xFF
    buf[at + 1] = (value >> 8) & 0xFF


@inline
def put_u32(buf: np.ndarray, at: int, value: int) -> None:
    """Also an int32 in two's complement."""
    for k in range(4):
        buf[at + k] = (value >> (8 * k)) & 0xFF


@inline
def put_u64(buf: np.ndarray, at: int, value: int) -> None:
    for k in range(8):
        buf[at + k] = (value >> (8 * k)) & 0xFF


@inline
def put_f32(buf: np.ndarray, at: int, value: float) -> None:
    """`value` rounded to float32 (to nearest, as struct's 'f' does), little-endian."""
    buf[at:at + 4].view(np.float32)[0] = value


@inline
def get_u32(buf: np.ndarray, at: int) -> int:
    """The little-endian uint32 at `at` (a reader of what `put_u32` writes)."""
    return int(buf[at:at + 4].view(np.uint32)[0])


@inline
def get_u64(buf: np.ndarray, at: int) -> int:
    return int(buf[at:at + 8].view(np.uint64)[0])


@inline
def get_f32(buf: np.ndarray, at: int) -> float:
    """The float32 at `at`, as a float64 (exactly: every float32 is one)."""
    return float(buf[at:at + 4].view(np.float32)[0])


@inline
def payload_of(frame: bytes, payload: np.ndarray) -> None:
    """A received frame's payload (MAVLink 2 or 1) into `payload`, its trimmed trailing zeros restored: every
    field then reads at its wire offset, whatever the sender trimmed."""
    header = PAYLOAD if frame[0] == STX_V2 else PAYLOAD_V1
    size = frame[1]
    for k in range(payload.size):
        payload[k] = frame[header + k] if k < size else 0


@inline
def frame_end(data: bytes, at: int, msgid: int, crc_extra: int, payload_size: int) -> int:
    """Where the frame that starts at `data[at]` ends when it is one whole, valid frame of message `msgid`; -1 when
    it is not. The scanner's checks: MAVLink 2, signed or not, or MAVLink 1; LEN within the message's
    `payload_size` and not 0; no unknown incompatibility flag; the X.25 checksum with CRC_EXTRA (a signature is not
    verified, as the scanner does not)."""
    size = len(data)
    if size - at < PAYLOAD_V1 + 1 + CRC_LEN:
        return -1
    v2 = data[at] == STX_V2
    if not v2 and data[at] != STX_V1:
        return -1
    length = int(data[at + 1])
    incompat = int(data[at + 2]) if v2 else 0
    if length == 0 or length > payload_size or incompat & ~INCOMPAT_SIGNED:
        return -1
    end = at + (PAYLOAD if v2 else PAYLOAD_V1) + length + CRC_LEN
    whole = end + (SIGNATURE_LEN if incompat & INCOMPAT_SIGNED else 0)
    if whole > size:  # checked before the id is read: the header's bytes are then all there
        return -1
    frame_id = (int(data[at + 7]) | int(data[at + 8]) << 8 | int(data[at + 9]) << 16) if v2 else int(data[at + 5])
    if frame_id != msgid or crc_x25(data, at + 1, end - 2, crc_extra) != (int(data[end - 2]) | int(data[end - 1]) << 8):
        return -1
    return whole


@inline
def crc_x25(buf: np.ndarray | bytes, start: int, end: int, crc_extra: int) -> int:
    """MAVLink's X.25 checksum of buf[start:end] followed by the CRC_EXTRA byte."""
    crc = 0xFFFF
    for k in range(start, end + 1):
        byte = int(buf[k]) if k < end else crc_extra
        tmp = (byte ^ crc) & 0xFF
        tmp = (tmp ^ (tmp << 4)) & 0xFF
        crc = ((crc >> 8) ^ (tmp << 8) ^ (tmp << 3) ^ (tmp >> 4)) & 0xFFFF
    return crc


@inline
def finish_frame(buf: np.ndarray, at: int, payload_size: int, seq: int, system_id: int, component_id: int,
                 msgid: int, crc_extra: int) -> int:
    """Header and checksum around the payload written at `at + PAYLOAD` (`payload_size` bytes before trimming);
    returns where the frame ends."""
    size = payload_size
    while size > 1 and buf[at + PAYLOAD + size - 1] == 0:
        size -= 1
    buf[at] = STX_V2
    buf[at + 1] = size
    buf[at + 2] = 0  # incompatibility flags: no signature
    buf[at + 3] = 0
    buf[at + 4] = seq & 0xFF
    buf[at + 5] = system_id
    buf[at + 6] = component_id
    buf[at + 7] = msgid & 0xFF
    buf[at + 8] = (msgid >> 8) & 0xFF
    buf[at + 9] = (msgid >> 16) & 0xFF
    end = at + PAYLOAD + size
    put_u16(buf, end, crc_x25(buf, at + 1, end, crc_extra))
    return end + 2
