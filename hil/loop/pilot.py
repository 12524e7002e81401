"""The pilot's contract: each step the loop shows the pilot the time, what the board has reported and the true
state; the pilot decides what the board is asked and what it flies. Pilots are in hil/pilots/."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from firmware_interface.board_report import BoardReport
from firmware_interface.board_requests import ParamSet, ProtocolMessage, Request
from firmware_interface.link import Message
from hil.scenario.reference import RefSample
from plant_fmu.state import PlantState

Ask = Request | ParamSet | ProtocolMessage  # what a pilot may send the board on its command link


@dataclass(frozen=True, slots=True)
class Decision:
    """What the pilot decided for one step."""

    phase: str  # the pilot's phase, as the recording says it ("mission" is the part the tracking is judged on)
    reference: RefSample | None  # the setpoint to stream, in the bench's (true) frame; None: no setpoint
    mission_t: float  # the mission clock (s) the environment and faults are timed on; -inf before it starts
    flying: bool  # the scenario's environment acts (before take-off and after landing: steady wind only)
    asks: tuple[Ask, ...] = ()  # sent to the board now, in this order
    board_offset_ned: np.ndarray | None = None  # the board's local frame - the truth: setpoints go out in its frame


@dataclass
class PilotView:
    """What a pilot sees, refreshed by the loop before each decision."""

    board: BoardReport  # heartbeat, ACKs, the latest of each message, texts, parameters read back
    command_link: str  # the board's command link, for messages
    emit: Callable[[str], None]  # a run event, stamped with the bench's time
    params_owed: dict[str, float | int] = field(default_factory=dict)  # told before arming (an int: INT32)
    now_s: float = 0.0  # the bench's time
    truth: PlantState | None = None  # the plant after the latest step
    outputs_armed: bool = False  # the board's actuator outputs say armed (HIL_ACTUATOR_CONTROLS)
    messages: list[Message] = field(default_factory=list)  # the board's messages since the last decision, in order

    def texts(self, count: int) -> str:
        """The board's last `count` texts, joined: a reason for an abort."""
        return "; ".join(text for _, text in self.board.status_texts[-count:])


class Pilot(Protocol):
    def decide(self, view: PilotView) -> Decision | None:
        """This step's decision; None once the flight is over. May raise RunAborted."""

    def progress(self) -> float:
        """How much of the flight is flown, 0 to 1 (for the progress line)."""

    def summary(self) -> dict[str, Any]:
        """What the pilot adds to the run's metrics (the phase it reached, ...)."""


class RunAborted(RuntimeError):
    """The run cannot go on: why, and the exit code that says so."""

    def __init__(self, reason: str, exit_code: int) -> None:
        super().__init__(reason)
        self.reason = reason
        self.exit_code = exit_code
