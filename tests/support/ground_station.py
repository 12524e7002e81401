"""An independent ground station written with pymavlink, as QGroundControl talks to a vehicle: its own heartbeat
(MAV_TYPE_GCS), the vehicle's heartbeats, a parameter read, and the mission downloaded with the mission protocol
(MISSION_REQUEST_LIST, MISSION_COUNT, MISSION_REQUEST_INT for each item, MISSION_ACK)."""

from __future__ import annotations

import time
from dataclasses import dataclass

from pymavlink import mavutil
from pymavlink.dialects.v20 import common

GCS_SYSTEM_ID = 254  # not MAVSDK's 245, not the vehicle's


@dataclass(frozen=True)
class DownloadedItem:
    command: int
    lat_deg: float
    lon_deg: float
    altitude_m: float


class GroundStation:
    def __init__(self, endpoint: str, vehicle_system_id: int) -> None:
        self.link = mavutil.mavlink_connection(endpoint, source_system=GCS_SYSTEM_ID, source_component=190,
                                               dialect="common")
        self.vehicle = vehicle_system_id
        self.heartbeats = 0
        self._last_own_heartbeat = 0.0

    def close(self) -> None:
        self.link.close()

    def _receive(self, types: list[str], timeout_s: float) -> common.MAVLink_message | None:
        """The next message of `types` from the vehicle, our own heartbeat sent at 1 Hz meanwhile."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if time.monotonic() - self._last_own_heartbeat > 1.0:
                self.link.mav.heartbeat_send(common.MAV_TYPE_GCS, common.MAV_AUTOPILOT_INVALID, 0, 0, 0)
                self._last_own_heartbeat = time.monotonic()
            message = self.link.recv_match(blocking=True, timeout=0.1)
            if message is None or message.get_srcSystem() != self.vehicle:
                continue
            if message.get_type() == "HEARTBEAT" and message.autopilot != common.MAV_AUTOPILOT_INVALID:
                self.heartbeats += 1
            if message.get_type() in types:
                return message
        return None

    def wait_heartbeats(self, count: int, timeout_s: float) -> bool:
        deadline = time.monotonic() + timeout_s
        while self.heartbeats < count and time.monotonic() < deadline:
            self._receive(["HEARTBEAT"], deadline - time.monotonic())
        return self.heartbeats >= count

    def read_param(self, name: str, timeout_s: float = 10.0) -> float | None:
        """The parameter's value, asked again every second; another client's PARAM_VALUEs (a relay sends PX4's
        answers to every ground station) are passed over, not taken for a lost answer."""
        for _ in range(int(timeout_s)):
            self.link.mav.param_request_read_send(self.vehicle, 1, name.encode(), -1)
            asked = time.monotonic()
            while (left_s := 1.0 - (time.monotonic() - asked)) > 0:
                message = self._receive(["PARAM_VALUE"], left_s)
                if message is not None and message.param_id == name:
                    return float(message.param_value)
        return None

    def download_mission(self, timeout_s: float = 20.0) -> list[DownloadedItem] | None:
        """The vehicle's mission, or None when the download did not complete."""
        deadline = time.monotonic() + timeout_s
        count = None
        while count is None and time.monotonic() < deadline:
            self.link.mav.mission_request_list_send(self.vehicle, 1, common.MAV_MISSION_TYPE_MISSION)
            reply = self._receive(["MISSION_COUNT"], 1.0)
            count = None if reply is None else reply.count
        items: list[DownloadedItem] = []
        while count is not None and len(items) < count and time.monotonic() < deadline:
            self.link.mav.mission_request_int_send(self.vehicle, 1, len(items), common.MAV_MISSION_TYPE_MISSION)
            item = self._receive(["MISSION_ITEM_INT"], 1.0)
            if item is not None and item.seq == len(items):
                items.append(DownloadedItem(item.command, item.x * 1e-7, item.y * 1e-7, item.z))
        if count is None or len(items) < count:
            return None
        self.link.mav.mission_ack_send(self.vehicle, 1, common.MAV_MISSION_ACCEPTED, common.MAV_MISSION_TYPE_MISSION)
        return items
