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

# Common-dialect messages newer than pymavlink's generated dialect, which PX4 v1.15 sends on its onboard
# links. The scanner validates them (CRC_EXTRA, maximum payload) and the link passes them through whole,
# undecoded, to the tlog and the ground-station relay. Figures computed with pymavlink's own
# generator (mavparse) from MAVLink's message_definitions/v1.0/common.xml at commit de1e078a.
PASSTHROUGH: dict[int, tuple[str, int, int]] = {  # id: (name, CRC_EXTRA, maximum payload bytes)
    8: ("LINK_NODE_STATUS", 117, 36),
    290: ("ESC_INFO", 251, 46),
    291: ("ESC_STATUS", 10, 57),
    380: ("TIME_ESTIMATE_TO_TARGET", 232, 20),
    410: ("EVENT", 160, 53),
    411: ("CURRENT_EVENT_SEQUENCE", 106, 3),
    436: ("CURRENT_MODE", 193, 9),
}
for _msgid, (_name, _crc_extra, _size) in PASSTHROUGH.items():
    SPECS.setdefault(_msgid, MessageSpec(_msgid, _crc_extra, _size))

# Messages pymavlink decodes whose definition in PX4 v1.15.4's MAVLink (its mavlink submodule, commit a3558d6 of
# mavlink/mavlink) has extension fields pymavlink's lacks: the mission protocol's opaque ids and MISSION_CURRENT's
# mission state, TIMESYNC's target, ... A MAVLink 2 receiver takes a payload longer than it knows and ignores the
# fields it does not (pymavlink's decoder does): the scanner allows their full length, computed with mavparse.
NEWER_EXTENSIONS: dict[int, tuple[str, int]] = {  # id: (name, maximum payload bytes in PX4's dialect)
    42: ("MISSION_CURRENT", 18),
    44: ("MISSION_COUNT", 9),
    47: ("MISSION_ACK", 8),
    82: ("SET_ATTITUDE_TARGET", 51),
    111: ("TIMESYNC", 18),
    126: ("SERIAL_CONTROL", 81),
}
for _msgid, (_name, _size) in NEWER_EXTENSIONS.items():
    SPECS[_msgid] = MessageSpec(_msgid, SPECS[_msgid].crc_extra, max(SPECS[_msgid].full_payload, _size))


def frame_msgid(frame: bytes) -> int:
    """The message id of a whole v2 or v1 frame."""
    return frame[7] | frame[8] << 8 | frame[9] << 16 if frame[0] == 0xFD else frame[5]


def message_name(msgid: int) -> str:
    """The MAVLink name of a message id, e.g. 105 -> "HIGHRES_IMU" (`MSG_<id>` for one we do not know)."""
    if msgid in common.mavlink_map:
        return str(common.mavlink_map[msgid].msgname)
    return PASSTHROUGH[msgid][0] if msgid in PASSTHROUGH else f"MSG_{msgid}"
