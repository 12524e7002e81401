"""A PX4 SITL the user started, on a port the bench holds (tcpin:127.0.0.1:4560), with its command link named
apart (--mavlink udpout:127.0.0.1:14620, a MAVLink instance added for the bench in PX4's shell). PX4 may be
started after the bench: it has a minute to connect."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from firmware_interface.board import SIMULATED, BoardSession
from firmware_interface.link import open_link
from hil.boards.handle import BoardHandle
from hil.boards.target import BoardPolicy, LinkSettings
from hil.scenario.schema import Scenario

MANUAL_SITL_WAIT_S = 60.0
SITL_HINT = ("is PX4 SITL running? Start it (in PX4-Autopilot: make px4_sitl none_iris; or let the bench start it with "
             "--px4 DIR); PX4 connects to 127.0.0.1:4560+instance")
SITL_PORT_POLICY = BoardPolicy("attached", "the board's own (PX4)",
                                wall_clock=False, ground_truth="for_log", px4=True, default_gcs=(),
                               stops_unread_streams=True)  # PX4 SITL has its own GCS port


@dataclass(frozen=True)
class SitlPortTarget:
    port: str  # any connection string that is not serial
    mavlink: str | None = None  # PX4 SITL's command link, e.g. udpout:127.0.0.1:14620; None: on `port`
    connect_timeout_s: float | None = None

    @property
    def label(self) -> str:
        return self.port

    def policy(self, scenario: Scenario) -> BoardPolicy:
        return SITL_PORT_POLICY

    def attach(self, scenario: Scenario, run_dir: Path, settings: LinkSettings) -> BoardHandle:
        settings.ready_to_step()  # a PX4 SITL may connect at once, and waits 1 s for its first HIL_SENSOR
        session = BoardSession(open_link(self.port, tap=settings.tap), SIMULATED, watchdog_s=settings.watchdog_s,
                               reversible_motors=settings.reversible_motors,
                               motor_count=settings.motor_count)
        handle = BoardHandle(session, session, f"sitl on {self.port}" + (f", commands on {self.mavlink}"
                                                                         if self.mavlink else ""))
        try:
            if self.mavlink:
                handle.command_session = BoardSession(open_link(self.mavlink, tap=settings.tap), SIMULATED,
                                               watchdog_s=settings.watchdog_s)
            session.wait_heartbeat(self.connect_timeout_s or MANUAL_SITL_WAIT_S, hint=SITL_HINT)
        except BaseException:
            handle.close()
            raise
        return handle
