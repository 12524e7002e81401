"""What a board has told a session: who it is, its state, its texts, its latest messages and its answers; what the
bench records, sums up and shows its pilots."""

from __future__ import annotations

from dataclasses import dataclass, field

from firmware_interface.link import Message


@dataclass(frozen=True)
class BoardInfo:
    system_id: int
    component_id: int
    autopilot: int
    vehicle_type: int
    hil_enabled: bool
    armed: bool


@dataclass
class BoardReport:
    """What the board last told us, for the bench's recording and summary."""

    info: BoardInfo | None = None
    armed: bool = False
    custom_mode: int = 0
    status_texts: list[tuple[int, str]] = field(default_factory=list)
    latest: dict[str, Message] = field(default_factory=dict)
    acks: dict[int, int] = field(default_factory=dict)
    params: dict[str, float] = field(default_factory=dict)  # PARAM_VALUE answers, by name
