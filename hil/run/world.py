"""The world of one run, built from its scenario: the plant FMU (through its mapping file, checked at rest before
any board starts), the sensor suite, the environment, and the faults on the board's links. One seed gives every
random part its own stream, in a fixed order, so that the same scenario and seed fly the same recording."""

from __future__ import annotations

from typing import Any

import numpy as np

from firmware_interface.link.faults import FaultSpec, LinkFaults
from hil.boards.handle import BoardHandle
from hil.loop.senders import senders_for
from hil.loop.stepper import World
from hil.scenario.environment import Environment
from hil.scenario.mission import MissionPlan
from hil.scenario.plant import mapping_path, plant_facts, scenario_parameters
from hil.scenario.schema import Scenario
from hil.sensors import SensorsConfig, SensorSuite
from plant_fmu import Plant
from plant_fmu.checks import check_at_rest


def step_us(scenario: Scenario) -> int:
    """The bench's step in integer µs (its clock); the plant's step follows it (equal to 1 / rate_hz whenever the
    rate divides 1 MHz, as every shipped one)."""
    return round(1e6 / scenario.rate_hz)


def vehicle_parameters(scenario: Scenario, plan: MissionPlan) -> dict[str, float]:
    """The plant's parameters (`scenario_parameters`), the vehicle waiting on the ground facing the mission's first
    heading (no yaw step at take-off) where its mapping names the parameter that sets it."""
    facts = plant_facts(mapping_path(scenario))
    heading = facts.mapping.heading_parameters(plan.sample(-plan.takeoff_s).yaw)
    return {**heading, **scenario_parameters(scenario, facts)}


def open_plant(scenario: Scenario, parameters: dict[str, float]) -> Plant:
    """The scenario's plant with its parameters, checked at rest (the sign check of `plant_fmu.checks`): raises
    MappingError (its lines name the mapping file and field) or PlantError before any board starts."""
    plant = Plant(parameters, mapping=mapping_path(scenario))
    try:
        check_at_rest(plant)
    except BaseException:
        plant.close()
        raise
    return plant


def reversible_rotors(parameters: dict[str, Any]) -> bool:
    """The paper's ideal rotors take -1..1, and PX4 outputs reversible motors that way."""
    return parameters.get("rotor_reversible", 0.0) > 0.5


def build_world(scenario: Scenario, board: BoardHandle, plant: Plant) -> World:
    """Sensors, environment and link faults from the scenario's seed, around the plant the run opened."""
    rng = np.random.default_rng(scenario.seed)
    sensor_rng, env_rng = rng.spawn(2)
    sensors = SensorsConfig.model_validate({**scenario.sensors.model_dump(),
                                            "faults": [*scenario.sensors.faults, *scenario.faults.sensors]})
    suite = SensorSuite(sensors, scenario.home, scenario.rate_hz, sensor_rng)
    environment = Environment(scenario, step_us(scenario) / 1e6, env_rng, plant.rotor_count)
    faults = _inject_link_faults(scenario, board, rng.spawn(1)[0]) if scenario.faults.link else []
    senders = senders_for(scenario, plant_facts(mapping_path(scenario)).built_in)
    return World(plant, suite, environment, scenario.home.frame, faults, senders)


def _inject_link_faults(scenario: Scenario, board: BoardHandle, rng: np.random.Generator) -> list[LinkFaults]:
    """The scenario's link faults on each link to the board (wall-clock effects: the run is paced)."""
    specs = [FaultSpec(f.kind, f.direction, f.start_s, f.end_s, f.probability, f.burst_frames,
                       f.delay_ms / 1000.0, f.jitter_ms / 1000.0, f.byte_error_rate)
             for f in scenario.faults.link]
    faults = []
    # one or two sessions; two streams are spawned either way (the RNG's draws do not depend on it)
    for session, stream in zip(board.sessions, rng.spawn(2), strict=False):
        session.inject_faults(LinkFaults(specs, stream))
        faults.append(session.link.faults)
    return [f for f in faults if f is not None]
