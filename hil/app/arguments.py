"""What several commands share: scenario files loaded with their problems printed, the Zenoh options."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any


def load_scenarios(paths: list[str]) -> tuple[list[tuple[str, Any]], int]:
    """The scenarios that load, each as (path, scenario), and how many did not (their problems printed)."""
    from hil.scenario.loader import ScenarioError, load_scenario

    scenarios, bad = [], 0
    for path in paths:
        try:
            scenarios.append((path, load_scenario(Path(path))))
        except ScenarioError as exc:
            for problem in exc.problems:
                print(problem, file=sys.stderr)
            bad += 1
    return scenarios, bad


def plant_refusal(path: str, exc: Exception) -> list[str]:
    """A plant the run cannot use (MappingError: one line per problem, naming the mapping file and its field;
    PlantError: the FMU's refusal), as lines naming the scenario file."""
    from plant_fmu.mapping import MappingError

    return [f"{path}: plant: {line}" for line in (exc.lines if isinstance(exc, MappingError) else [str(exc)])]


def plant_at_rest_problems(path: str, scenario: Any) -> list[str]:
    """The scenario's plant opened with its parameters and checked at rest (the start-up check of `hil run`):
    the lines of `plant_refusal`, none when it passes."""
    from hil.run.world import open_plant, vehicle_parameters
    from hil.scenario.mission import MissionPlan
    from plant_fmu import PlantError
    from plant_fmu.mapping import MappingError

    try:
        with open_plant(scenario, vehicle_parameters(scenario, MissionPlan.build(scenario))):
            return []
    except (MappingError, PlantError) as exc:
        return plant_refusal(path, exc)


def zenoh_options(args: argparse.Namespace):
    from hil.outputs.zenoh_session import ZenohOptions

    endpoints = bool(args.zenoh_connect or args.zenoh_listen)
    return ZenohOptions(connect=args.zenoh_connect or [], listen=args.zenoh_listen or [],
                        config_file=Path(args.zenoh_config) if args.zenoh_config else None,
                        multicast_scouting=not endpoints)


def add_zenoh_arguments(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("Zenoh", "default: a peer that finds others on this machine by multicast "
                                               "scouting; with endpoints, scouting is off")
    group.add_argument("--zenoh-connect", action="append", metavar="ENDPOINT", help="e.g. tcp/192.0.2.10:7447")
    group.add_argument("--zenoh-listen", action="append", metavar="ENDPOINT", help="e.g. tcp/0.0.0.0:7447")
    group.add_argument("--zenoh-config", metavar="FILE", help="a Zenoh JSON5 configuration file")
