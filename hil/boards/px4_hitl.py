"""PX4's HITL code path started by the bench from a px4_sitl_nolockstep build, its HIL link on a pty: the bench
then flies the same serial path as with a Pixhawk on /dev/ttyACM0, on the wall clock."""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from pathlib import Path

from firmware_interface.board import ON_OWN_CLOCK, BoardSession
from firmware_interface.link import Link, open_pty_pair
from hil.boards.gcs_relay import DEFAULT_GCS
from hil.boards.handle import BoardHandle, abandon_attach
from hil.boards.px4 import Px4Build, Px4Process, claim_instance
from hil.boards.px4.hitl_startup import write_hitl_startup
from hil.boards.px4.parameters import battery_parameters, px4_parameters, rotor_parameters
from hil.boards.px4.process import child_setup
from hil.boards.px4_sitl import PX4_START_TIMEOUT_S
from hil.boards.target import BoardPolicy, LinkSettings
from hil.scenario.failsafe import px4_parameter_values
from hil.scenario.schema import Scenario

HITL_POLICY = BoardPolicy("px4_hitl", "PX4 (its own estimator and controllers)",
                          wall_clock=True, ground_truth="none", px4=True, default_gcs=(DEFAULT_GCS,),
                          stops_unread_streams=True)


@dataclass(frozen=True)
class Px4HitlTarget:
    build: Px4Build
    connect_timeout_s: float | None = None  # for its first heartbeat (PX4_START_TIMEOUT_S)

    @property
    def label(self) -> str:
        return f"PX4 HITL rehearsal from {self.build.root}"

    def policy(self, scenario: Scenario) -> BoardPolicy:
        return HITL_POLICY

    def attach(self, scenario: Scenario, run_dir: Path, settings: LinkSettings) -> BoardHandle:
        pair = open_pty_pair()
        claim, _ = claim_instance(lambda n: n)
        try:
            rotors = rotor_parameters(settings.rotors) if settings.rotors is not None else {}
            script = write_hitl_startup(run_dir.resolve() / "px4-hitl.rcS", pair.slave_path,  # PX4 runs elsewhere
                                        rotors | px4_parameter_values(scenario.board.params)
                                        | battery_parameters(scenario))
            px4 = Px4Process(self.build, claim, run_dir / "px4", run_dir / "px4.log", {"HEADLESS": "1"},
                             extra_args=("-s", str(script)), preexec=partial(child_setup, claim.number))
        except BaseException:
            claim.release()
            pair.master.close()
            pair.release_slave()
            raise
        handle: BoardHandle | None = None
        try:  # from PX4's start on, whatever stops the attach (a stop signal too) stops PX4
            session = BoardSession(Link(pair.master, tap=settings.tap), ON_OWN_CLOCK, watchdog_s=settings.watchdog_s,
                                   reversible_motors=settings.reversible_motors, motor_count=settings.motor_count)
            handle = BoardHandle(session, session, f"PX4 HITL rehearsal, instance {claim.number} ({self.build.root}) "
                                 f"on {pair.slave_path}", px4, px4_parameters(scenario, settings.rotors))
            session.wait_heartbeat(self.connect_timeout_s or PX4_START_TIMEOUT_S,
                                   hint=f"is {self.build.root} a px4_sitl_nolockstep build? see {px4.log_path}",
                                   still_starting=px4.check_starting)
        except BaseException:
            abandon_attach(handle, px4, pair.master)
            raise
        finally:
            pair.release_slave()  # PX4 holds its end now
        return handle
