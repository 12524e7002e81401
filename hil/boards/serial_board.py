"""A Pixhawk (or any PX4 board with SYS_HITL=1) on a serial port: HITL on the board's own clock."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from firmware_interface.board import ON_OWN_CLOCK, BoardSession
from firmware_interface.link import open_link
from hil.boards.gcs_relay import DEFAULT_GCS
from hil.boards.handle import BoardHandle
from hil.boards.target import BoardPolicy, LinkSettings
from hil.scenario.schema import Scenario

SERIAL_WAIT_S = 10.0  # a Pixhawk sends its heartbeat at 1 Hz from boot
SERIAL_POLICY = BoardPolicy("attached", "the board's own (PX4)",
                                wall_clock=True, ground_truth="none", px4=True, default_gcs=(DEFAULT_GCS,),
                            stops_unread_streams=True)


@dataclass(frozen=True)
class SerialBoardTarget:
    port: str  # a serial connection string: /dev/ttyACM0, /dev/ttyACM0,921600, serial:PATH:BAUD
    baud: int | None = None  # where `port` names none
    connect_timeout_s: float | None = None

    @property
    def label(self) -> str:
        return self.port

    def policy(self, scenario: Scenario) -> BoardPolicy:
        return SERIAL_POLICY

    def attach(self, scenario: Scenario, run_dir: Path, settings: LinkSettings) -> BoardHandle:
        session = BoardSession(open_link(self.port, tap=settings.tap, baud=self.baud), ON_OWN_CLOCK,
                               watchdog_s=settings.watchdog_s, reversible_motors=settings.reversible_motors,
                               motor_count=settings.motor_count)
        handle = BoardHandle(session, session, f"hitl on {self.port}")
        try:
            session.wait_heartbeat(self.connect_timeout_s or SERIAL_WAIT_S)
        except BaseException:
            handle.close()
            raise
        return handle
