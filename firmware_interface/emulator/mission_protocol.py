"""The MAVLink mission protocol, served as PX4 v1.15.4's MavlinkMissionManager serves it (mavlink_mission.cpp).

Upload: MISSION_COUNT → MISSION_REQUEST(_INT) per item (re-sent every 0.25 s until the item comes) → MISSION_ITEM
(_INT) … → MISSION_ACK; a transfer silent for 5 s ends with "Operation timeout". Download: MISSION_REQUEST_LIST →
MISSION_COUNT → MISSION_REQUEST(_INT) / MISSION_ITEM(_INT) … ← MISSION_ACK. MISSION_CLEAR_ALL, MISSION_SET_CURRENT;
MISSION_CURRENT and MISSION_ITEM_REACHED on change and at 1 Hz (the last reached item ten more times). One
transfer at a time, with one partner (system, component); the STATUSTEXTs are PX4's. Geofence and rally lists
are accepted and forgotten (PX4 with none configured answers an empty list, as here). Like PX4 after boot, the
first request of an upload is MISSION_REQUEST; an item that comes as MISSION_ITEM_INT switches to the _INT
messages. The protocol's timers run on the wall clock: the ground station on the other side lives in it.
"""

from __future__ import annotations

import struct
import time
import zlib
from collections.abc import Callable
from enum import Enum
from typing import Any

from pymavlink.dialects.v20.common import (
    MAV_COMP_ID_ALL,
    MAV_COMP_ID_MISSIONPLANNER,
    MAV_MISSION_ACCEPTED,
    MAV_MISSION_ERROR,
    MAV_MISSION_NO_SPACE,
    MAV_MISSION_OPERATION_CANCELLED,
    MAV_MISSION_TYPE_ALL,
    MAV_MISSION_TYPE_MISSION,
    MAV_MISSION_UNSUPPORTED,
    MAV_SEVERITY_CRITICAL,
    MAV_SEVERITY_INFO,
)

from firmware_interface.emulator.mission_items import MissionItem, item_fields, parse_item

RETRY_S, TIMEOUT_S = 0.25, 5.0  # MAVLINK_MISSION_RETRY_TIMEOUT_DEFAULT, MAVLINK_MISSION_PROTOCOL_TIMEOUT_DEFAULT
MAX_ITEMS = 65534  # NUM_MISSIONS_SUPPORTED on POSIX (SITL)
STATUS_PERIOD_US = 1_000_000
REACHED_REPEATS = 10
Send = Callable[[str, dict[str, Any]], None]
Status = Callable[[int, str], None]


class Transfer(Enum):
    IDLE = "idle"
    GETLIST = "receiving"  # an upload from the partner
    SENDLIST = "sending"  # a download to the partner


class MissionServer:
    """The stored mission and the transfers that change or read it."""

    def __init__(self, system_id: int, send: Send, status: Status, on_mission: Callable[[], None],
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.system_id = system_id
        self.send, self.status, self.on_mission, self.clock = send, status, on_mission, clock
        self.items: list[MissionItem] = []
        self.crc = 0  # PX4's CRC32 over the items as sent: an identical upload leaves the mission as it is
        self.current_seq = 0
        self.reached_seq = -1
        self.finished = False  # flown to its end: AUTO.MISSION starts it again from the first item
        self.state = Transfer.IDLE
        self.mission_type = MAV_MISSION_TYPE_MISSION
        self.int_mode = False
        self.partner = (0, 0)
        self.seq = 0  # the next item of the transfer
        self.count = 0
        self.received: list[MissionItem] = []
        self.received_crc = 0
        self.received_current = -1
        self.last_sent_s = self.last_recv_s = 0.0
        self._next_status_us = 0
        self._reached_repeats = 0

    # --- messages in ---------------------------------------------------------------------------------------
    def handle(self, msg: Any) -> None:
        if msg.target_system != self.system_id or msg.target_component not in (1, MAV_COMP_ID_MISSIONPLANNER,
                                                                                MAV_COMP_ID_ALL):
            return
        handler = _HANDLERS.get(msg.get_type())
        if handler is not None:
            handler(self, msg)

    def _on_count(self, msg: Any) -> None:
        if self.state is not Transfer.IDLE:
            if self.state is Transfer.GETLIST and self.seq == 0:  # our first request was lost: ask again
                self.last_recv_s = self.clock()
                self._request()
                return
            self.status(MAV_SEVERITY_CRITICAL, "WPM: REJ. CMD: Busy" if self.state is Transfer.GETLIST
                        else "WPM: IGN MISSION_COUNT: Busy")
            self._ack(MAV_MISSION_ERROR, _sender(msg), msg.mission_type)
            return
        self.last_recv_s = self.clock()
        if msg.count > MAX_ITEMS:
            self._ack(MAV_MISSION_NO_SPACE, _sender(msg), msg.mission_type)
        elif msg.count == 0:
            self._clear(msg.mission_type)
            self._ack(MAV_MISSION_ACCEPTED, _sender(msg), msg.mission_type)
        else:
            self.state, self.mission_type, self.partner = Transfer.GETLIST, msg.mission_type, _sender(msg)
            self.seq, self.count, self.received, self.received_crc, self.received_current = 0, msg.count, [], 0, -1
            self._request()

    def _on_item(self, msg: Any) -> None:
        self.int_mode = msg.get_type() == "MISSION_ITEM_INT"
        if msg.mission_type != self.mission_type:
            self._ack(MAV_MISSION_ERROR, self.partner, msg.mission_type)
        elif self.state is Transfer.IDLE:
            if self.seq == msg.seq + 1:  # the last item again: our ACK was lost
                self._ack(MAV_MISSION_ACCEPTED, self.partner, msg.mission_type)
            else:
                self.status(MAV_SEVERITY_CRITICAL, "IGN MISSION_ITEM: No transfer")
                self._ack(MAV_MISSION_ERROR, self.partner, msg.mission_type)
        elif self.state is Transfer.SENDLIST:
            self.status(MAV_SEVERITY_CRITICAL, "IGN MISSION_ITEM: Busy")
            self._ack(MAV_MISSION_ERROR, self.partner, msg.mission_type)
        else:
            self.last_recv_s = self.clock()
            if msg.seq == self.seq:  # any other is a duplicate or from the future: ignored, as PX4
                self._take(msg)

    def _take(self, msg: Any) -> None:
        item = parse_item(msg, self.int_mode)
        if self.mission_type == MAV_MISSION_TYPE_MISSION and isinstance(item, int):
            self.status(MAV_SEVERITY_CRITICAL, "IGN MISSION_ITEM: Invalid item")
            self._ack(item, self.partner, self.mission_type)
            self.state = Transfer.IDLE
            return
        if isinstance(item, MissionItem):
            self.received.append(item)
        self.received_crc = _crc32_item(msg, self.int_mode, self.received_crc)
        if msg.current:
            self.received_current = msg.seq
        self.seq = msg.seq + 1
        if self.seq < self.count:
            self._request()
            return
        self.state = Transfer.IDLE
        if self.mission_type == MAV_MISSION_TYPE_MISSION and self.received_crc != self.crc:
            self.items, self.crc = self.received, self.received_crc
            self.current_seq, self.reached_seq, self.finished = max(self.received_current, 0), -1, False
            self.on_mission()
        self._ack(MAV_MISSION_ACCEPTED, self.partner, self.mission_type)

    def _on_request_list(self, msg: Any) -> None:
        if self.seq == self._stored_count():  # everything went out and a new list is asked: the ACK was lost
            self.state = Transfer.IDLE
        if self.state is not Transfer.IDLE and not (self.state is Transfer.SENDLIST
                                                    and msg.mission_type == self.mission_type):
            self.status(MAV_SEVERITY_INFO, "Mission download request ignored, already active")
            return
        self.last_recv_s = self.clock()
        self.state, self.mission_type, self.partner = Transfer.SENDLIST, msg.mission_type, _sender(msg)
        self.seq, self.count = 0, self._stored_count()
        self.last_sent_s = self.clock()
        self.send("MISSION_COUNT", {"target_system": self.partner[0], "target_component": self.partner[1],
                                    "count": self.count, "mission_type": self.mission_type})

    def _on_request(self, msg: Any) -> None:
        self.int_mode = msg.get_type() == "MISSION_REQUEST_INT"
        if _sender(msg) != self.partner:
            self.status(MAV_SEVERITY_CRITICAL, "WPM: REJ. CMD: partner id mismatch")
        elif self.state is Transfer.GETLIST:
            self.status(MAV_SEVERITY_CRITICAL, "WPM: REJ. CMD: Busy")
        elif self.state is Transfer.SENDLIST and msg.mission_type == self.mission_type:
            self.last_recv_s = self.clock()
            if msg.seq == self.seq and self.seq < self.count:
                self.seq += 1
            elif msg.seq != self.seq - 1 or msg.seq >= self._stored_count():
                self.state = Transfer.IDLE
                self._ack(MAV_MISSION_ERROR, self.partner, self.mission_type)
                self.status(MAV_SEVERITY_CRITICAL, "WPM: REJ. CMD: Req. WP was unexpected")
                return
            self._send_item(msg.seq)

    def _on_ack(self, msg: Any) -> None:
        if _sender(msg) != self.partner:
            self.status(MAV_SEVERITY_CRITICAL, "REJ. WP CMD: partner id mismatch")
        elif self.state is Transfer.SENDLIST and msg.mission_type == self.mission_type:
            self.last_recv_s = self.clock()
            self.state = Transfer.IDLE
        elif self.state is Transfer.GETLIST:
            if msg.type == MAV_MISSION_UNSUPPORTED:  # the partner wants the other encoding
                self.int_mode = not self.int_mode
                self._request()
            elif msg.type == MAV_MISSION_OPERATION_CANCELLED:
                self.state = Transfer.IDLE

    def _on_clear_all(self, msg: Any) -> None:
        if self.state is not Transfer.IDLE:
            self.status(MAV_SEVERITY_CRITICAL, "WPM: IGN CLEAR CMD: Busy")
            return
        self.last_recv_s = self.clock()
        self._clear(msg.mission_type)
        self._ack(MAV_MISSION_ACCEPTED, _sender(msg), msg.mission_type)

    def _on_set_current(self, msg: Any) -> None:
        if self.state is not Transfer.IDLE:
            self.status(MAV_SEVERITY_CRITICAL, "WPM: IGN WP CURR CMD: Busy")
        elif not self.set_current(msg.seq):
            self.status(MAV_SEVERITY_CRITICAL, "WPM: WP CURR CMD: Not in list")

    # --- the navigator's side ------------------------------------------------------------------------------
    def set_current(self, seq: int) -> bool:
        """Make `seq` the current item (MISSION_SET_CURRENT, DO_SET_MISSION_CURRENT, MISSION_START); False when
        the mission has no such item."""
        if not 0 <= seq < len(self.items):
            return False
        self.current_seq, self.finished = seq, False
        self.on_mission()
        self.send_current()
        return True

    def advance(self, seq: int) -> None:
        """The navigator moved on to item `seq`."""
        if seq != self.current_seq:
            self.current_seq = seq
            self.send_current()

    def reached(self, seq: int) -> None:
        self.reached_seq, self._reached_repeats = seq, 0
        self.send("MISSION_ITEM_REACHED", {"seq": seq})

    def send_current(self) -> None:
        self.send("MISSION_CURRENT", {"seq": self.current_seq, "total": len(self.items) or 0xFFFF,
                                      "mission_state": 0, "mission_mode": 0})

    def stream(self, t_us: int) -> None:
        """MISSION_CURRENT at 1 Hz of simulated time, and the last reached item ten more times."""
        if t_us < self._next_status_us:
            return
        self._next_status_us = t_us + STATUS_PERIOD_US
        self.send_current()
        if self.items and self.reached_seq >= 0 and self._reached_repeats < REACHED_REPEATS:
            self._reached_repeats += 1
            self.send("MISSION_ITEM_REACHED", {"seq": self.reached_seq})

    def service(self) -> None:
        """Re-ask for an item not yet come; give up on a transfer silent for TIMEOUT_S."""
        now = self.clock()
        if self.state is Transfer.GETLIST and now - self.last_sent_s > RETRY_S:
            self._request()
        elif self.state is not Transfer.IDLE and now - self.last_recv_s > TIMEOUT_S:
            self.status(MAV_SEVERITY_CRITICAL, "Operation timeout")
            self.state = Transfer.IDLE

    # --- messages out ----------------------------------------------------------------------------------------
    def _request(self) -> None:
        self.last_sent_s = self.clock()
        self.send("MISSION_REQUEST_INT" if self.int_mode else "MISSION_REQUEST",
                  {"target_system": self.partner[0], "target_component": self.partner[1], "seq": self.seq,
                   "mission_type": self.mission_type})

    def _send_item(self, seq: int) -> None:
        self.last_sent_s = self.clock()
        fields = item_fields(self.items[seq], seq, seq == self.current_seq, self.int_mode)
        self.send("MISSION_ITEM_INT" if self.int_mode else "MISSION_ITEM",
                  {**fields, "target_system": self.partner[0], "target_component": self.partner[1],
                   "mission_type": self.mission_type})

    def _ack(self, result: int, to: tuple[int, int], mission_type: int) -> None:
        self.send("MISSION_ACK", {"target_system": to[0], "target_component": to[1], "type": result,
                                  "mission_type": mission_type})

    def _stored_count(self) -> int:
        return len(self.items) if self.mission_type == MAV_MISSION_TYPE_MISSION else 0

    def _clear(self, mission_type: int) -> None:
        if mission_type in (MAV_MISSION_TYPE_MISSION, MAV_MISSION_TYPE_ALL):
            self.items, self.crc, self.current_seq, self.reached_seq, self.finished = [], 0, 0, -1, False
            self.on_mission()


def _sender(msg: Any) -> tuple[int, int]:
    return msg.get_srcSystem(), msg.get_srcComponent()


def _crc32_item(msg: Any, int_encoded: bool, crc: int) -> int:
    """PX4's crc32_for_mission_item: NuttX's crc32part (no pre- or post-inversion) over the packed frame,
    command, autocontinue and the seven params (an _INT item's x and y as their int32 bytes)."""
    xy = struct.pack("<ii", msg.x, msg.y) if int_encoded else struct.pack("<ff", msg.x, msg.y)
    data = struct.pack("<BHB4f", msg.frame, msg.command, msg.autocontinue, msg.param1, msg.param2, msg.param3,
                       msg.param4) + xy + struct.pack("<f", msg.z)
    return ~zlib.crc32(data, ~crc & 0xFFFFFFFF) & 0xFFFFFFFF


_HANDLERS: dict[str, Callable[[MissionServer, Any], None]] = {
    "MISSION_COUNT": MissionServer._on_count, "MISSION_ITEM": MissionServer._on_item,
    "MISSION_ITEM_INT": MissionServer._on_item, "MISSION_REQUEST_LIST": MissionServer._on_request_list,
    "MISSION_REQUEST": MissionServer._on_request, "MISSION_REQUEST_INT": MissionServer._on_request,
    "MISSION_ACK": MissionServer._on_ack, "MISSION_CLEAR_ALL": MissionServer._on_clear_all,
    "MISSION_SET_CURRENT": MissionServer._on_set_current,
}
MISSION_MESSAGES = frozenset(_HANDLERS)
