"""The pilot kinds by the name a scenario gives them (`pilot:`); adding one is its module plus one line here."""

from __future__ import annotations

from collections.abc import Callable

from hil.loop.pilot import Pilot
from hil.pilots.bench import BenchPilot
from hil.pilots.external import ExternalPilot
from hil.pilots.mission import MissionPilot
from hil.pilots.sticks import SticksPilot
from hil.scenario.mission import MissionPlan
from hil.scenario.pilot_spec import MissionPilotSpec
from hil.scenario.schema import Scenario


def _mission(scenario: Scenario, plan: MissionPlan, dt_us: int) -> Pilot:
    assert isinstance(scenario.pilot, MissionPilotSpec)
    return MissionPilot(scenario.pilot.items, scenario.duration_s, dt_us)


PILOTS: dict[str, Callable[[Scenario, MissionPlan, int], Pilot]] = {
    "bench": lambda scenario, plan, dt_us: BenchPilot(plan, str(scenario.end), dt_us),
    "mission": _mission,
    "external": lambda scenario, plan, dt_us: ExternalPilot(str(scenario.end), scenario.duration_s, dt_us),
    "sticks": lambda scenario, plan, dt_us: SticksPilot(str(scenario.end), scenario.duration_s, dt_us),
}


def make_pilot(scenario: Scenario, plan: MissionPlan, dt_us: int) -> Pilot:
    """The pilot the scenario names, flying `plan` (the bench pilot's reference) on a bench clock of `dt_us` steps."""
    return PILOTS[scenario.pilot.type](scenario, plan, dt_us)
