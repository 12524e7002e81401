"""Reference trajectories (NED, SI): hover, the paper's helix, waypoints, power-line patrol; one module each.

Each module holds two classes: the model of the scenario's `reference:` section (`HoverRef`: the file's
words and units, degrees, bounds, validated once as the file loads) and the trajectory it builds
(`HoverRef.trajectory()` → `Hover`: a frozen dataclass in SI and radians, sampled at every bench step).
They stay two because the trajectories are also built where there is no file: the take-off and landing
segments of the plan are `Waypoints` from run-time positions and a yaw in radians (a yaw through degrees and
back would not come back bit for bit), a patrol is waypoints, tests fly a helix about any centre.
Speed does not decide it: sampling the helix from a pydantic model's fields costs what sampling the
dataclass does (5.3 against 5.1 µs on this machine, measured with the same maths).

`Reference`, the discriminated union below, is the registry: a type is one module here and one member of the
union. Everything else follows from the union: the schema (`Scenario.reference`), `hil check`, the plan
(`MissionPlan.build` takes any member as a `TrajectorySource`, which mypy checks for every member) and the
conformance test (tests/test_reference_conformance.py runs over every member and its JSON-schema examples).
"""

from __future__ import annotations

from typing import Annotated

from pydantic import Field

from hil.scenario.reference.base import FieldProblem, RefSample, Trajectory, TrajectorySource
from hil.scenario.reference.helix import Helix, HelixRef
from hil.scenario.reference.hover import Hover, HoverRef
from hil.scenario.reference.patrol import Patrol, PatrolRef
from hil.scenario.reference.waypoints import Waypoints, WaypointsRef

Reference = Annotated[HoverRef | HelixRef | WaypointsRef | PatrolRef, Field(discriminator="type")]

__all__ = ["FieldProblem", "Helix", "HelixRef", "Hover", "HoverRef", "Patrol", "PatrolRef", "RefSample", "Reference",
           "Trajectory", "TrajectorySource", "Waypoints", "WaypointsRef"]
