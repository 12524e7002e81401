"""The checks of a scenario that depend on who flies: how its run may end, whether its mission can be flown within
the scenario's bounds, and whether its expectations can be judged on that flight."""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

from hil.scenario.mission_items import RELATIVE_FRAMES, PlanItem
from hil.scenario.pilot_spec import ENDS, BenchPilotSpec
from hil.sensors.geodesy import MAX_DISTANCE_M, Home

if TYPE_CHECKING:
    from hil.scenario.schema import Bounds, Scenario

_WHY_NOT = {"land": "the bench lands the vehicle only when it flies it (pilot: bench)",
            "disarm": "the bench disarms the vehicle only when it flies it (pilot: bench)",
            "landed": "the bench pilot lands by itself: end: land",
            "duration": "a mission ends when the vehicle has landed and disarmed, or fails at duration_s"}
NEEDS_PLAN = ("mission_completed", "max_cross_track_m")  # judged against the planned mission
NEEDS_REFERENCE = ("max_error_m",)  # judged against the bench pilot's reference


def resolve_end(scenario: Scenario) -> None:
    """A scenario without `end:` ends as its pilot's runs end by default."""
    if scenario.end is None:
        scenario.end = ENDS[scenario.pilot.type][0]


Problem = tuple[tuple[str | int, ...], Any, str]  # the field's location, its value, what is wrong and expected


def pilot_problems(scenario: Scenario) -> Iterator[Problem]:
    kind, allowed = scenario.pilot.type, ENDS[scenario.pilot.type]
    if scenario.end not in allowed:
        yield (("end",), scenario.end, f"a run with pilot: {kind} cannot end '{scenario.end}': "
                                      f"{_WHY_NOT[str(scenario.end)]}; expected {' or '.join(allowed)}")
    pilot = scenario.pilot
    if not isinstance(pilot, BenchPilotSpec):
        source = f" (from {pilot.plan})" if pilot.plan else ""
        for index, item in enumerate(pilot.items):
            reason = item.problem() or _beyond_bounds(item, scenario.home)
            if reason is not None:
                yield (("pilot", "items", index), item.describe(), f"mission item {index}{source}: {reason}")
    if scenario.expect is not None:
        for loc, bounds in ((("expect",), scenario.expect), (("expect", "px4"), scenario.expect.px4)):
            if bounds is not None:
                yield from _expectation_errors(scenario, loc, bounds)


def _beyond_bounds(item: PlanItem, home: Home) -> str | None:
    """An item farther from home than a scenario's positions may be (MAX_DISTANCE_M), horizontally or in height."""
    if not item.positional:
        return None
    height = item.altitude_m if item.frame in RELATIVE_FRAMES else item.altitude_m - home.alt_msl_m
    if abs(height) > MAX_DISTANCE_M:
        return (f"{height:g} m above home, beyond the {MAX_DISTANCE_M / 1000:g} km bound of a scenario; expected "
                f"an altitude within it")
    where = item.lat_lon_deg
    if where is None:
        return None
    north, east, _ = home.frame.to_ned(where[0], where[1], home.alt_msl_m)
    distance = math.hypot(north, east)
    if distance > MAX_DISTANCE_M:
        return (f"{item.describe()} is {distance / 1000:.1f} km from home ({home.lat_deg:g}, {home.lon_deg:g}), "
                f"beyond the {MAX_DISTANCE_M / 1000:g} km bound of a scenario; expected an item within it (a plan "
                "made for another place? set home: to its planned home)")
    return None


def _expectation_errors(scenario: Scenario, loc: tuple[str, ...], bounds: Bounds) -> Iterator[Problem]:
    """An expectation that the scenario's flight cannot be judged on."""
    pilot = scenario.pilot
    planned = not isinstance(pilot, BenchPilotSpec) and pilot.planned
    for name in NEEDS_PLAN:
        if getattr(bounds, name) is not None and not planned:
            yield ((*loc, name), getattr(bounds, name),
                   f"{name} is judged against a planned mission; expected pilot: mission, or pilot: external "
                   "with the plan: it is expected to fly")
    if not isinstance(pilot, BenchPilotSpec):
        for name in NEEDS_REFERENCE:
            if getattr(bounds, name) is not None:
                yield ((*loc, name), getattr(bounds, name),
                       f"{name} is judged against the bench pilot's reference, which pilot: {pilot.type} does "
                       "not fly; a mission's path is judged with max_cross_track_m")
