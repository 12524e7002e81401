"""The contract of a board kind (`BoardTarget`) and the policy the run reads from it, so that nothing outside a
kind's own module asks which kind it is."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Literal, Protocol

from firmware_interface.link import FrameTap
from hil.boards.handle import BoardHandle
from hil.scenario.plant import RotorGeometry
from hil.scenario.schema import Scenario

QUAD_MOTORS = 4  # motors read from a board whose rotors the run does not set (its airframe's, a quad)

# What the true state is sent for: nothing (a real board, PX4's HITL path), PX4 SITL's log (HIL_STATE_QUATERNION,
# its *_groundtruth topics), or the emulator's flight code (ODOMETRY at float precision, `state_source: truth`)
GroundTruthUse = Literal["none", "for_log", "to_fly"]


@dataclass(frozen=True)
class BoardPolicy:
    kind: str  # meta.json's board_kind: emulator, px4_sitl, px4_hitl, attached
    autopilot: str  # what flies on it, for the summary: the emulator's controller, or PX4's own
    wall_clock: bool  # the board keeps its own time: the run is paced on the wall clock, replies never awaited
    ground_truth: GroundTruthUse
    px4: bool  # PX4's own flight code flies (the expectations meant for PX4 apply)
    default_gcs: tuple[str, ...]  # relay endpoints when the user names none
    stops_unread_streams: bool  # may be asked to stop the streams nobody reads (PX4 streams ~400 messages a second)


@dataclass(frozen=True)
class LinkSettings:
    """How the run wants its links to the board, and the plant's rotors the board must mix for."""

    watchdog_s: float = 1.0
    tap: FrameTap | None = None  # sees every frame (the tlog)
    reversible_motors: bool = False  # the plant's rotors take -1..1 (the paper's ideal actuators)
    speed_factor: float = 1.0  # a lockstep run paced at this many times the wall clock (PX4_SIM_SPEED_FACTOR)
    rotors: RotorGeometry | None = None  # the plant's rotors, PX4's motor order (None: the board's airframe's)
    # returns once the bench can send its first step: a board that times its wait for the first sensor frame from the
    # moment it connects (PX4 SITL: an error after 1 s) is started only then
    ready_to_step: Callable[[], None] = lambda: None
    spin_wait: bool = False  # a board the bench starts polls for the bench's frames as the bench does for its replies

    @property
    def motor_count(self) -> int:
        """How many of HIL_ACTUATOR_CONTROLS' outputs drive the plant's rotors."""
        return self.rotors.count if self.rotors is not None else QUAD_MOTORS


class BoardTarget(Protocol):
    """A board the bench can fly against: its name, its policy, and how it attaches (returns once it has spoken;
    raises BoardError or LinkError otherwise, with nothing left running)."""

    @property
    def label(self) -> str: ...

    def policy(self, scenario: Scenario) -> BoardPolicy: ...

    def attach(self, scenario: Scenario, run_dir: Path, settings: LinkSettings) -> BoardHandle: ...
