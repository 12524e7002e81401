"""What the commander's checks know of the vehicle's links and supplies, as PX4 v1.15.4 gathers it: the ground
station's heartbeats (Commander.cpp data link checks), stick input (rcAndDataLinkCheck.cpp), the battery a
battery component reports (mavlink_receiver.cpp handle_message_battery_status, batteryCheck.cpp) and whether the
position estimate is aided (EKF2_NOAID_TOUT; estimatorCheck.cpp's one-second probation after it returns).
All on simulated time."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from pymavlink.dialects.v20.common import MAV_SEVERITY_EMERGENCY, MAV_SEVERITY_INFO, MAV_TYPE_GCS

from firmware_interface import hil_codec as codec
from firmware_interface.emulator.manual_control import ManualInput

if TYPE_CHECKING:
    from firmware_interface.emulator.firmware import EmulatedBoard

WARNINGS = ("", "low", "critical", "emergency")  # battery_status_s::BATTERY_WARNING_NONE … _EMERGENCY
POSITION_PROBATION_US = 1_000_000
UNKNOWN = 0xFFFF  # a BATTERY_STATUS cell voltage that is not given


class Health:
    def __init__(self, board: EmulatedBoard) -> None:
        self.board = board
        self.manual = ManualInput()
        self.manual_lost_at_arming = True  # no stick input when armed: its loss is no failsafe (failsafe.cpp)
        self.gcs_heartbeat_us: int | None = None
        self.gcs_lost = True  # as PX4 boots: lost until a ground station's first heartbeat
        self.battery: Any = None  # the last BATTERY_STATUS
        self.battery_warning = ""
        self.fix_since_us: int | None = None  # good fixes continuously since
        self.last_fix_us: int | None = None
        self.position_lost = False

    # --- messages in -------------------------------------------------------------------------------------
    def on_heartbeat(self, msg: Any, now_us: int) -> None:
        if msg.type != MAV_TYPE_GCS:
            return
        if self.gcs_lost:
            self.gcs_lost = False
            if self.gcs_heartbeat_us is not None:
                self.board.status(MAV_SEVERITY_INFO, "GCS connection regained")
        self.gcs_heartbeat_us = now_us

    def on_battery(self, msg: Any) -> None:
        """From a component of this vehicle other than the autopilot (PX4 ignores the rest)."""
        if msg.get_srcSystem() != self.board.config.system_id or msg.get_srcComponent() == 1:
            return
        self.battery = msg
        params = self.board.params
        remaining = msg.battery_remaining / 100.0  # PX4 reads −1 (unknown) as −1 %, an emergency
        level = 3 if remaining < params["BAT_EMERGEN_THR"] else 2 if remaining < params["BAT_CRIT_THR"] else \
            1 if remaining < params["BAT_LOW_THR"] else 0
        now = WARNINGS.index(self.battery_warning)
        if level > now or (level < now and not self.board.armed):  # armed, a warning only grows
            self.battery_warning = WARNINGS[level]
            if level > now:
                self.board.status(MAV_SEVERITY_EMERGENCY, "Low battery level")

    def on_fix(self, fix: codec.GpsFix, now_us: int) -> None:
        if fix.fix_type < 3:
            return
        if self.fix_since_us is None or self.last_fix_us is None or \
                now_us - self.last_fix_us > self._noaid_timeout_us():
            self.fix_since_us = now_us
        self.last_fix_us = now_us

    # --- at the navigator's rate -----------------------------------------------------------------------------
    def tick(self, now_us: int) -> None:
        params = self.board.params
        if self.manual.fresh(now_us, params["COM_RC_LOSS_T"]):
            self.manual_lost_at_arming = False
        heard = self.gcs_heartbeat_us
        if not self.gcs_lost and heard is not None and now_us - heard > params["COM_DL_LOSS_T"] * 1e6:
            self.gcs_lost = True
            self.board.status(MAV_SEVERITY_INFO, "Connection to ground station lost")
        last = self.last_fix_us
        if last is not None and now_us - last > self._noaid_timeout_us():
            self.position_lost = True
        elif self.fix_since_us is not None and now_us - self.fix_since_us >= POSITION_PROBATION_US:
            self.position_lost = False

    def on_arm(self, now_us: int) -> None:
        self.manual_lost_at_arming = not self.manual.fresh(now_us, self.board.params["COM_RC_LOSS_T"])

    def _noaid_timeout_us(self) -> float:
        return self.board.params["EKF2_NOAID_TOUT"]

    # --- what the checks read ----------------------------------------------------------------------------------
    def manual_control_fresh(self, now_us: int) -> bool:
        return self.manual.fresh(now_us, self.board.params["COM_RC_LOSS_T"])

    def manual_control_lost(self, now_us: int) -> bool:
        """Stick input gone, having been there since arming (PX4 ignores a loss it armed with)."""
        return not self.manual_control_fresh(now_us) and not self.manual_lost_at_arming

    def battery_mv_ca_percent(self) -> tuple[int, int, int]:
        """SYS_STATUS's battery fields (PX4's: the voltage summed over the cells, UINT16_MAX, −1, −1 unknown)."""
        battery = self.battery
        if battery is None:
            return 0xFFFF, -1, -1
        millivolts = sum(v for v in battery.voltages if v != UNKNOWN)
        return min(millivolts, 0xFFFF), battery.current_battery, battery.battery_remaining
