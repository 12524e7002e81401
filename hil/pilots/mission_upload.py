"""A mission uploaded to the board with MAVLink's mission protocol, as a ground station does it, one step at a time:
MISSION_COUNT; each MISSION_REQUEST_INT (or MISSION_REQUEST, which PX4 sends first after boot) answered with that
item as MISSION_ITEM_INT; MISSION_ACK ends it. Nothing waits: each step takes the board's messages and returns what
to send now. The board re-requests an item it did not get (PX4 after 250 ms); the count is sent again while no
request has come."""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any

from pymavlink.dialects.v20 import common

from firmware_interface.board import BENCH_COMPONENT_ID
from firmware_interface.board_requests import ProtocolMessage
from firmware_interface.link import Message
from hil.scenario.mission_items import PlanItem

COUNT_RETRY_S = 1.0  # simulated: MISSION_COUNT again while the board has not asked for an item
SILENCE_LIMIT_S = 10.0  # no answer for this long: the upload failed (PX4 gives up after 5 s itself)
REQUESTS = ("MISSION_REQUEST_INT", "MISSION_REQUEST")


def item_message(seq: int, item: PlanItem) -> ProtocolMessage:
    """MISSION_ITEM_INT for `item` at `seq`: latitude and longitude in 1e-7 degrees, NaN where QGroundControl wrote
    null (a yaw left to the autopilot)."""
    params = [math.nan if value is None else float(value) for value in item.params]
    where = item.lat_lon_deg
    x, y = (round(where[0] * 1e7), round(where[1] * 1e7)) if where is not None else (0, 0)
    fields: dict[str, Any] = {"seq": seq, "frame": item.frame, "command": item.command, "current": int(seq == 0),
                              "autocontinue": int(item.autoContinue), "param1": params[0], "param2": params[1],
                              "param3": params[2], "param4": params[3], "x": x, "y": y,
                              "z": params[6] if not math.isnan(params[6]) else 0.0,
                              "mission_type": common.MAV_MISSION_TYPE_MISSION}
    return ProtocolMessage("MISSION_ITEM_INT", tuple(fields.items()))


def _to_bench(message: Message) -> bool:
    """A mission-protocol message for the bench (the board also answers other ground stations on the link)."""
    return (getattr(message, "target_component", None) == BENCH_COMPONENT_ID
            and getattr(message, "mission_type", common.MAV_MISSION_TYPE_MISSION) == common.MAV_MISSION_TYPE_MISSION)


class MissionUpload:
    """One upload, from its first step to the board's MISSION_ACK."""

    def __init__(self, items: list[PlanItem]) -> None:
        self.items = items
        self.accepted = False
        self.failure: str | None = None  # why the board refused or never answered
        self.items_sent = 0
        self._started_s: float | None = None
        self._heard_s = 0.0  # the board's last answer
        self._count_sent_s = -math.inf
        self._requested = False

    @property
    def done(self) -> bool:
        return self.accepted or self.failure is not None

    def step(self, now_s: float, messages: Iterable[Message]) -> list[ProtocolMessage]:
        """What to send this step, given the board's messages since the last one."""
        if self._started_s is None:
            self._started_s = self._heard_s = now_s
        out: list[ProtocolMessage] = []
        for message in messages:
            kind = message.get_type()
            if kind not in (*REQUESTS, "MISSION_ACK") or not _to_bench(message):
                continue
            self._heard_s = now_s
            if kind == "MISSION_ACK":
                self._acknowledged(message.type)
            elif 0 <= message.seq < len(self.items):
                self._requested = True
                out.append(item_message(message.seq, self.items[message.seq]))
                self.items_sent += 1
        if self.done:
            return out
        if now_s - self._heard_s > SILENCE_LIMIT_S:
            self.failure = (f"no answer to the mission upload for {SILENCE_LIMIT_S:g} s "
                            f"({'items were requested' if self._requested else 'no item was requested'})")
        elif not self._requested and now_s - self._count_sent_s >= COUNT_RETRY_S:
            out.append(ProtocolMessage("MISSION_COUNT", (("count", len(self.items)),
                                                         ("mission_type", common.MAV_MISSION_TYPE_MISSION))))
            self._count_sent_s = now_s
        return out

    def _acknowledged(self, result: int) -> None:
        if result == common.MAV_MISSION_ACCEPTED:
            self.accepted = True
            return
        entry = common.enums["MAV_MISSION_RESULT"].get(result)
        self.failure = f"the board refused the mission: {entry.name if entry is not None else result}"
