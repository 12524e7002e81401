"""A PX4 mission as QGroundControl plans it: the items of a `.plan` file (JSON: `mission.items`, each a
"SimpleItem" with a MAV_CMD, a MAV_FRAME and seven params), read with the standard library, or the same items
written inline in a scenario.

Only the items a PX4 multicopter mission flies and the bench can judge are accepted (`FLOWN`): waypoints (with
their acceptance radius and hold time), take-off, land, loiter for a time, return to launch, change speed.
Positions are WGS84 latitude and longitude with an altitude relative to home (MAV_FRAME_GLOBAL_RELATIVE_ALT, what
QGroundControl writes) or above mean sea level (MAV_FRAME_GLOBAL); JSON has no NaN, so QGroundControl writes
`null` where MAVLink means NaN (a yaw left to the autopilot).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator
from pymavlink.dialects.v20 import common

FLOWN = {common.MAV_CMD_NAV_WAYPOINT: "NAV_WAYPOINT", common.MAV_CMD_NAV_LOITER_TIME: "NAV_LOITER_TIME",
         common.MAV_CMD_NAV_RETURN_TO_LAUNCH: "NAV_RETURN_TO_LAUNCH", common.MAV_CMD_NAV_LAND: "NAV_LAND",
         common.MAV_CMD_NAV_TAKEOFF: "NAV_TAKEOFF", common.MAV_CMD_DO_CHANGE_SPEED: "DO_CHANGE_SPEED"}
POSITIONAL = frozenset({common.MAV_CMD_NAV_WAYPOINT, common.MAV_CMD_NAV_LOITER_TIME, common.MAV_CMD_NAV_LAND,
                        common.MAV_CMD_NAV_TAKEOFF})
RELATIVE_FRAMES = frozenset({common.MAV_FRAME_GLOBAL_RELATIVE_ALT, common.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT})
AMSL_FRAMES = frozenset({common.MAV_FRAME_GLOBAL, common.MAV_FRAME_GLOBAL_INT})
MAX_PLAN_BYTES = 10_000_000  # a plan of 10 000 waypoints is ~4 MB of QGroundControl's JSON
MAX_ITEMS = 10_000
Params = tuple[float | None, float | None, float | None, float | None, float | None, float | None, float | None]


def command_name(command: int) -> str:
    entry = common.enums["MAV_CMD"].get(command)
    return entry.name.removeprefix("MAV_CMD_") if entry is not None else f"MAV_CMD {command}"


def simple_item_only(kind: str) -> str:
    if kind != "SimpleItem":
        raise ValueError(f"a {kind} (QGroundControl's survey, corridor scan or structure scan) is not flown: "
                         "expected SimpleItem items")
    return kind


def _flown_list() -> str:
    return ", ".join(f"{name} ({number})" for number, name in FLOWN.items())


class PlanItem(BaseModel):
    """One mission item as a `.plan` file holds it (QGroundControl's SimpleItem); the keys QGroundControl adds
    for its own editor (Altitude, AltitudeMode, AMSLAltAboveTerrain, doJumpId) are accepted and not used."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    type: str = "SimpleItem"
    command: int = Field(description="MAV_CMD, as a number (16) or a name (NAV_WAYPOINT)")
    frame: int = common.MAV_FRAME_GLOBAL_RELATIVE_ALT
    params: Params = (0.0, 0.0, 0.0, None, None, None, None)
    autoContinue: bool = True
    doJumpId: int | None = None
    Altitude: float | None = None
    AltitudeMode: int | None = None
    AMSLAltAboveTerrain: float | None = None

    @field_validator("type")
    @classmethod
    def _simple(cls, kind: str) -> str:
        return simple_item_only(kind)

    @field_validator("command", mode="before")
    @classmethod
    def _flown(cls, command: Any) -> int:
        if isinstance(command, str):
            name = command.upper().removeprefix("MAV_CMD_")
            number = getattr(common, f"MAV_CMD_{name}", None)
            if not isinstance(number, int):
                raise ValueError(f"unknown command {command!r}; expected one of {_flown_list()}")
            command = number
        if isinstance(command, int) and not isinstance(command, bool) and command not in FLOWN:
            raise ValueError(f"{command_name(command)} ({command}) is not an item the bench flies and judges; "
                             f"expected one of {_flown_list()}")
        return command

    @field_validator("params")
    @classmethod
    def _finite(cls, params: Params) -> Params:
        if any(p is not None and not math.isfinite(p) for p in params):
            raise ValueError("a param is NaN or infinite; JSON writes a NaN param as null")
        return params

    @property
    def positional(self) -> bool:
        return self.command in POSITIONAL

    @property
    def lat_lon_deg(self) -> tuple[float, float] | None:
        """Where the item is (params 5 and 6); None for an item without a position."""
        lat, lon = self.params[4], self.params[5]
        return None if lat is None or lon is None or not self.positional else (lat, lon)

    @property
    def altitude_m(self) -> float:
        return self.params[6] or 0.0

    def problem(self) -> str | None:
        """What makes the item unflyable, as one line; None when it can be flown."""
        if not self.positional:
            return None
        if self.frame not in RELATIVE_FRAMES | AMSL_FRAMES:
            return (f"frame {self.frame} is not flown: expected {common.MAV_FRAME_GLOBAL_RELATIVE_ALT} "
                    f"(altitude relative to home) or {common.MAV_FRAME_GLOBAL} (above mean sea level)")
        if self.lat_lon_deg is None:  # PX4 would fly a take-off or landing at 0, 0 to the equator
            return f"{command_name(self.command)} without a latitude and longitude (params 5 and 6)"
        if self.lat_lon_deg is not None and not (-90 <= self.lat_lon_deg[0] <= 90 and -180 <= self.lat_lon_deg[1]
                                                 <= 180):
            return f"latitude {self.lat_lon_deg[0]:g}, longitude {self.lat_lon_deg[1]:g} are not on the Earth"
        return None

    def describe(self) -> str:
        where = self.lat_lon_deg
        at = f" at {where[0]:.7f}, {where[1]:.7f}" if where is not None else ""
        return f"{command_name(self.command)}{at}{f', {self.altitude_m:g} m' if self.positional else ''}"


class PlanFileError(ValueError):
    """A .plan file that cannot be read as a mission: the message is one line naming the file."""


def read_plan_file(path: Path) -> list[dict[str, Any]]:
    """The raw items of a QGroundControl .plan file (validated as PlanItems by the scenario)."""
    try:
        with path.open("rb") as file:
            raw = file.read(MAX_PLAN_BYTES + 1)
    except FileNotFoundError:
        raise PlanFileError(f"{path}: no such file") from None
    except OSError as exc:
        raise PlanFileError(f"{path}: cannot read: {exc.strerror or exc}") from None
    if len(raw) > MAX_PLAN_BYTES:
        raise PlanFileError(f"{path}: larger than {MAX_PLAN_BYTES:,} bytes; not a mission plan")
    try:
        plan = json.loads(raw.decode("utf-8-sig"))
    except UnicodeDecodeError as exc:
        raise PlanFileError(f"{path}: not UTF-8 text (byte offset {exc.start}); a .plan file is JSON") from None
    except json.JSONDecodeError as exc:
        raise PlanFileError(f"{path}: not JSON ({exc.msg} at line {exc.lineno}, column {exc.colno}); a .plan "
                            "file is what QGroundControl saves with Plan > File > Save") from None
    except RecursionError:
        raise PlanFileError(f"{path}: nested too deep to be a mission plan") from None
    mission = plan.get("mission") if isinstance(plan, dict) else None
    items = mission.get("items") if isinstance(mission, dict) else None
    if not isinstance(items, list):
        raise PlanFileError(f"{path}: not a QGroundControl plan: no list at mission.items")
    if len(items) > MAX_ITEMS:
        raise PlanFileError(f"{path}: {len(items)} mission items, more than the {MAX_ITEMS} the bench takes")
    return items


def validate_items(raw_items: list[Any], source: str) -> list[PlanItem]:
    """The items as PlanItems; PlanFileError naming `source` and the first bad item otherwise."""
    items = []
    for index, raw in enumerate(raw_items):
        kind = raw.get("type", "SimpleItem") if isinstance(raw, dict) else None
        if kind != "SimpleItem":  # the item's other keys are another kind's: its type says it all
            try:
                simple_item_only(kind if isinstance(kind, str) else type(raw).__name__)
            except ValueError as exc:
                raise PlanFileError(f"{source}: mission item {index}: type: {exc}") from None
        try:
            items.append(PlanItem.model_validate(raw))
        except ValidationError as exc:
            error = exc.errors(include_url=False)[0]
            field = ".".join(str(part) for part in error["loc"])
            message = error["msg"].removeprefix("Value error, ")
            more = f" (and {exc.error_count() - 1} more problems)" if exc.error_count() > 1 else ""
            raise PlanFileError(f"{source}: mission item {index}{': ' + field if field else ''}: {message}{more}") \
                from None
    return items
