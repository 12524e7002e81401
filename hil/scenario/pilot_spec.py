"""Who flies the vehicle, as a scenario says it (`pilot:`): the bench itself (`bench`, the default), PX4's own
mission started by the bench acting as the ground station (`mission`), someone else (`external`:
QGroundControl, a joystick through it, MAVSDK, MAVROS), the bench being only the world, or a person with sticks
(`sticks`: the scenario's `manual_control:`, after the bench has selected POSCTL and armed).

A mission is a QGroundControl `.plan` file (`plan:`, relative to the scenario file) or the same items inline
(`items:`). The plan is read when the scenario loads, and the resolved scenario carries its items beside the plan's
path, so that a run directory's scenario.yaml flies again without the file: where both are given, the items are the
mission. An external pilot may name the mission it is expected to
fly, for the judge (mission_completed, max_cross_track_m); the bench never uploads it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BeforeValidator, Field, ValidationInfo, model_validator

from hil.scenario.fields import SCENARIO_DIR, ScenarioModel
from hil.scenario.mission_items import MAX_ITEMS, PlanItem, read_plan_file, validate_items


class BenchPilotSpec(ScenarioModel):
    """The bench flies: it arms, switches to offboard, streams the scenario's reference and lands."""

    type: Literal["bench"] = "bench"


class _Planned(ScenarioModel):
    plan: str | None = Field(None, description="a QGroundControl .plan file (relative to the scenario file)")
    items: list[PlanItem] = Field(default_factory=list, max_length=MAX_ITEMS)

    @model_validator(mode="before")
    @classmethod
    def _read_plan(cls, data: Any, info: ValidationInfo) -> Any:
        """The plan file's items, read now; a scenario read back from a run directory has them already."""
        if not isinstance(data, dict) or data.get("plan") is None or data.get("items"):
            return data  # no plan, or its items already read (a resolved scenario: they are what flew)
        base = (info.context or {}).get(SCENARIO_DIR)
        path = Path(str(data["plan"])).expanduser()
        if base is not None and not path.is_absolute():
            path = Path(base) / path
        items = validate_items(read_plan_file(path), str(path))
        if not items:
            raise ValueError(f"{path}: the plan's mission has no items; expected at least a take-off")
        return {**data, "plan": str(path.resolve()), "items": items}

    @property
    def planned(self) -> bool:
        return bool(self.items)


class MissionPilotSpec(_Planned):
    """The bench is the ground station: it uploads the mission, arms, starts it, and then only watches."""

    type: Literal["mission"]

    @model_validator(mode="after")
    def _has_items(self) -> MissionPilotSpec:
        if not self.items:
            raise ValueError("a mission pilot needs its mission: plan: FILE (a QGroundControl .plan) or items: "
                             "[...], at least one item")
        return self


class ExternalPilotSpec(_Planned):
    """Someone else flies; `plan`/`items`, when given, is the mission they are expected to fly (judged only)."""

    type: Literal["external"]


class SticksPilotSpec(_Planned):
    """A person with sticks: the bench selects POSCTL and arms, as a pilot does from the ground station, and from
    then on only the scenario's `manual_control:` sticks fly (the take-off, the flight, the landing); `plan`/`items`,
    when given, is the mission the person is expected to fly (judged only)."""

    type: Literal["sticks"]


PilotSpec = Annotated[BenchPilotSpec | MissionPilotSpec | ExternalPilotSpec | SticksPilotSpec,
                      Field(discriminator="type"),
                      BeforeValidator(lambda value: {"type": value} if isinstance(value, str) else value)]

# how a run may end, per pilot, the default first: land (the bench lands it), disarm (the bench disarms it where
# it is), landed (the board has taken off, landed and disarmed), duration (at duration_s, or Ctrl-C)
End = Literal["land", "disarm", "landed", "duration"]
ENDS: dict[str, tuple[End, ...]] = {"bench": ("land", "disarm"), "mission": ("landed",),
                                   "external": ("landed", "duration"), "sticks": ("landed", "duration")}
