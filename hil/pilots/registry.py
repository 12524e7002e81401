"""The pilot kinds by the name a scenario gives them (`pilot:`); adding one is its module plus one line here."""

from __future__ import annotations

from collections.abc import Callable

from hil.loop.pilot import Pilot
from hil.pilots.bench import BenchPilot
from hil.scenario.mission import MissionPlan
from hil.scenario.schema import Scenario

PILOTS: dict[str, Callable[[Scenario, MissionPlan, int], Pilot]] = {
    "bench": lambda scenario, plan, dt_us: BenchPilot(plan, scenario.end, dt_us),
}


def make_pilot(scenario: Scenario, plan: MissionPlan, dt_us: int) -> Pilot:
    """The pilot the scenario names, flying `plan` on a bench clock of `dt_us` steps."""
    return PILOTS["bench"](scenario, plan, dt_us)
