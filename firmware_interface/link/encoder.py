"""Fast MAVLink v2 frame encoding straight from field values.

pymavlink builds a message object per frame; on the 250 Hz hot path we pack the payload
with the message's own struct (wire order), trim trailing zeros as MAVLink 2 requires,
and add header and CRC. Tests check the bytes equal pymavlink's `msg.pack()` output.
"""

from __future__ import annotations

import struct
from collections.abc import Mapping, Sequence
from typing import Any

import fastcrc
import numpy as np

from firmware_interface.link.dialect import MAVLINK
from firmware_interface.link.scanner import STX_V2

_HEADER = struct.Struct("<BBBBBBBHB")
_crc16 = fastcrc.crc16.mcrf4xx


class _Layout:
    """How one message class lays its fields on the wire."""

    def __init__(self, cls: Any) -> None:  # a pymavlink message class (untyped)
        self.msgid: int = cls.id
        self.crc_extra = bytes((cls.crc_extra,))
        self.struct: struct.Struct = cls.unpacker
        types = dict(zip(cls.fieldnames, cls.fieldtypes, strict=True))
        self.fields: list[tuple[str, int]] = []
        for name, count in zip(cls.ordered_fieldnames, cls.array_lengths, strict=True):
            flat = count if count and types[name] != "char" else 0
            self.fields.append((name, flat))


_LAYOUTS: dict[Any, _Layout] = {}


def _layout(cls: Any) -> _Layout:
    layout = _LAYOUTS.get(cls)
    if layout is None:
        layout = _LAYOUTS[cls] = _Layout(cls)
    return layout


class FrameEncoder:
    """Encodes frames for one sender (system id, component id), numbering them 0..255."""

    def __init__(self, system_id: int, component_id: int) -> None:
        self.system_id = system_id
        self.component_id = component_id
        self.seq = 0

    def numbering_into(self, out: np.ndarray) -> None:
        """(next sequence number, system id, component id) into `out`, as compiled packers take them (three item
        writes: a tuple assigned to the array cost ~0.8 µs a step on the lockstep round trip)."""
        out[0], out[1], out[2] = self.seq, self.system_id, self.component_id

    def encode(self, cls: Any, values: Mapping[str, Any]) -> bytes:
        """Frame for message class `cls` (e.g. MAVLink_hil_sensor_message) from field values."""
        layout = _layout(cls)
        flat: list[Any] = []
        for name, count in layout.fields:
            value = values[name]
            if count:
                items: Sequence[Any] = value
                if len(items) != count:
                    raise ValueError(f"{cls.msgname}.{name} needs {count} values, got {len(items)}")
                flat.extend(items)
            else:
                flat.append(value.encode() if isinstance(value, str) else value)
        payload = layout.struct.pack(*flat).rstrip(b"\x00") or b"\x00"
        msgid = layout.msgid
        header = _HEADER.pack(STX_V2, len(payload), 0, 0, self.seq, self.system_id, self.component_id,
                              msgid & 0xFFFF, msgid >> 16)
        self.seq = (self.seq + 1) & 0xFF
        body = header[1:] + payload
        crc = _crc16(body + layout.crc_extra)
        return header[:1] + body + struct.pack("<H", crc)


def message_class(name: str) -> type:
    """pymavlink's class for a message name such as 'HIL_SENSOR'."""
    return getattr(MAVLINK, f"MAVLink_{name.lower()}_message")
