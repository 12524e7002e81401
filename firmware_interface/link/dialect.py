"""What the scanner and encoder need to know of each MAVLink message: ids, sizes, CRC_EXTRA.

Taken from pymavlink's generated common dialect, so it always matches the decoder.
"""

from __future__ import annotations

from dataclasses import dataclass

from pymavlink.dialects.v20 import common

MAVLINK = common


@dataclass(frozen=True)
class MessageSpec:
    msgid: int
    crc_extra: int
    full_payload: int  # bytes, extensions included (the most LEN can be)


SPECS: dict[int, MessageSpec] = {
    msgid: MessageSpec(msgid, cls.crc_extra, cls.unpacker.size) for msgid, cls in common.mavlink_map.items()
}
