"""How far a board got through its mission, from what it reported: MISSION_ITEM_REACHED, MISSION_CURRENT and the
mode in its HEARTBEAT.

PX4 v1.15.4 does not report every item reached (seen in its flights and its ULog's mission_result): its take-off
item becomes a climb and is never reported, a speed change is reported as soon as it is read, and a final
return-to-launch item switches the vehicle to AUTO.RTL without a report. So an item counts as reached when the
board reports it reached, or when its MISSION_CURRENT moves on from that item to a later one (the navigator only
leaves an item it has completed); a final return-to-launch item when the board enters AUTO.RTL after every item
before it, and a final landing item when the vehicle is on the ground after them. Items in between that the
current item jumps over are not reached, and a current item that goes back means the mission was not flown in
order.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Generic, TypeVar

from pymavlink.dialects.v20 import common

from hil.scenario.mission_items import PlanItem

When = TypeVar("When")  # the moment a thing was decided, as the caller keeps it


@dataclass
class MissionProgress(Generic[When]):
    items: list[PlanItem]
    reached: dict[int, When] = field(default_factory=dict)  # item -> when it was reached, each once
    current: int | None = None  # the board's MISSION_CURRENT
    went_back: bool = False  # the current item decreased during the mission

    @property
    def count(self) -> int:
        return len(self.items)

    @property
    def complete(self) -> bool:
        return len(self.reached) == self.count and not self.went_back

    def item_reached(self, seq: int, when: When) -> None:
        if 0 <= seq < self.count:
            self.reached.setdefault(seq, when)

    def current_item(self, seq: int, when: When) -> None:
        if self.current is not None and seq > self.current:
            self.item_reached(self.current, when)
        elif self.current is not None and seq < self.current and self.reached:
            self.went_back = True
        self.current = seq

    def mode(self, mode: str, when: When) -> None:
        if mode == "AUTO.RTL":
            self._final(common.MAV_CMD_NAV_RETURN_TO_LAUNCH, when)

    def landed(self, when: When) -> None:
        self._final(common.MAV_CMD_NAV_LAND, when)

    def _final(self, command: int, when: When) -> None:
        """The last item done by what it makes the vehicle do, once every item before it is reached."""
        last = self.count - 1
        if self.count and self.items[last].command == command and all(i in self.reached for i in range(last)):
            self.item_reached(last, when)

    def missing(self) -> list[int]:
        return [seq for seq in range(self.count) if seq not in self.reached]
