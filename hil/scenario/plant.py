"""The scenario's plant: the mapping file its `plant:` field names (our own FMU for the vehicle preset's rotors
when it names none), what that plant offers (rotors, settable parameters, the contract inputs it maps), and the
scenario's problems against it, found from the mapping file and the FMU's modelDescription.xml alone (no FMU
is instantiated: the sign check at rest is `plant_fmu.checks`, run by `hil check` and at `hil run`'s start-up).
"""

from __future__ import annotations

import functools
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from firmware_interface.airframes import AIRFRAMES
from hil.scenario.vehicles import hover_power_w, pack_max_power_w, plant_parameters, thrust_to_weight
from plant_fmu.checks import check_rotor_count
from plant_fmu.mapping import BUILT_IN, Mapping, MappingError, RotorGeometry, default_mapping_path, load_mapping
from plant_fmu.resolve import PARAMETER_CAUSALITIES, resolve
from plant_fmu.variables import PARAMETER_NAMES

if TYPE_CHECKING:
    from hil.scenario.schema import Scenario

__all__ = ["PlantFacts", "RotorGeometry", "mapping_path", "plant_facts", "plant_problems", "scenario_parameters"]

Loc = tuple[str | int, ...]


@dataclass(frozen=True)
class PlantFacts:
    """What a mapped plant offers the scenario."""

    mapping: Mapping
    parameters: frozenset[str]  # the FMU's settable parameters
    inputs: frozenset[str]  # the contract's inputs the mapping gives the FMU

    @property
    def built_in(self) -> bool:
        return self.mapping.spec.fmu == BUILT_IN


def mapping_path(scenario: Scenario) -> Path:
    """The `plant:` file, or our own FMU's mapping for the airframe the vehicle preset names."""
    if scenario.plant is not None:
        return Path(scenario.plant)
    return default_mapping_path(AIRFRAMES[scenario.vehicle.preset].rotor_count)


def plant_facts(path: Path) -> PlantFacts:
    """The mapping read and, for a foreign FMU, checked against its modelDescription.xml (every name, causality,
    type and unit); MappingError names the mapping file and its field. Read again only when a file changes."""
    path = path.resolve()
    return _facts(path, _mtime(path))


def _mtime(path: Path) -> int:
    try:
        return path.stat().st_mtime_ns
    except OSError:
        return 0  # load_mapping says what is wrong with it


@functools.lru_cache(maxsize=32)
def _facts(path: Path, mtime_ns: int) -> PlantFacts:
    mapping = load_mapping(path)
    spec = mapping.spec
    inputs = set(spec.inputs) | ({"rotor_health"} if all(r.health for r in spec.rotors.list) else set())
    if spec.fmu == BUILT_IN:  # our FMU: its variable table is its modelDescription.xml (no build needed here)
        return PlantFacts(mapping, frozenset(PARAMETER_NAMES), frozenset(inputs))
    fmu = mapping.fmu_path()
    assert fmu is not None
    resolved = resolve(mapping, fmu)
    parameters = {name for name, v in resolved.variables.items() if v.causality in PARAMETER_CAUSALITIES}
    return PlantFacts(mapping, frozenset(parameters), frozenset(inputs))


def scenario_parameters(scenario: Scenario, facts: PlantFacts) -> dict[str, float]:
    """The FMU parameters the scenario sets: our FMU takes the vehicle preset with its overrides; a foreign FMU,
    whose names are its own, only the overrides."""
    overrides = scenario.vehicle.overrides
    battery = scenario.battery.fmu_parameters(every=facts.built_in) if scenario.battery is not None else {}
    return {**(plant_parameters(scenario.vehicle.preset, overrides) if facts.built_in else overrides), **battery}


def plant_problems(scenario: Scenario) -> Iterator[tuple[Loc, Any, str]]:
    """(location, value, reason) for each way the scenario does not fit its plant."""
    where: Loc = ("plant",) if scenario.plant is not None else ("vehicle", "preset")
    try:
        facts = plant_facts(mapping_path(scenario))
    except MappingError as exc:
        for line in exc.lines:
            yield where, scenario.plant, line
        return
    airframe = scenario.board.airframe or scenario.vehicle.preset
    try:
        check_rotor_count(facts.mapping, AIRFRAMES[airframe].rotor_count, airframe)
    except MappingError as exc:
        yield (where if scenario.plant is not None else ("board", "airframe")), airframe, exc.lines[0]
    yield from _parameter_problems(scenario, facts)
    yield from _input_problems(scenario, facts)
    yield from _lift_problems(scenario, facts)
    if scenario.battery is not None:
        yield from _battery_problems(scenario, facts)


def _parameter_problems(scenario: Scenario, facts: PlantFacts) -> Iterator[tuple[Loc, Any, str]]:
    fmu = "our FMU" if facts.built_in else Path(facts.mapping.spec.fmu).name
    fixed = facts.mapping.spec.parameters
    for name, value in scenario.vehicle.overrides.items():
        if name not in facts.parameters:
            yield ("vehicle", name), value, (f"no parameter {name!r} in {fmu} (plant {facts.mapping.source.name}); "
                                             "expected one of its parameters")
        elif name in fixed:
            yield ("vehicle", name), value, (f"fixed to {fixed[name]:g} by the plant mapping "
                                             f"{facts.mapping.source.name}; choose another plant or vehicle preset")


# the scenario's fields that drive each optional input of the plant contract
def _inputs_used(scenario: Scenario) -> Iterator[tuple[str, Loc]]:
    wind = scenario.wind
    if any(wind.steady_ned) or wind.gusts or wind.turbulence is not None:
        yield "wind", ("wind",)
    for name, port in (("force_ned", "force"), ("torque_frd", "torque")):
        if any(item != 0 for item in getattr(scenario.disturbance, name)):
            yield port, ("disturbance", name)
    if any(step.mass_kg for step in scenario.payload):
        yield "payload_mass", ("payload",)
    if scenario.faults.motors:
        yield "rotor_health", ("faults", "motors")


def _input_problems(scenario: Scenario, facts: PlantFacts) -> Iterator[tuple[Loc, Any, str]]:
    for port, loc in _inputs_used(scenario):
        if port not in facts.inputs:
            yield loc, None, (f"the plant mapping {facts.mapping.source.name} gives its FMU no {port} input; "
                              f"expected a plant that maps it, or no {loc[-1]} in this scenario")
    for index, fault in enumerate(scenario.faults.motors):
        if fault.motor > facts.mapping.rotor_count:
            yield ("faults", "motors", index, "motor"), fault.motor, (
                f"motor {fault.motor}: the plant {facts.mapping.source.name} has {facts.mapping.rotor_count} rotors; "
                f"expected 1 to {facts.mapping.rotor_count}")


def _lift_problems(scenario: Scenario, facts: PlantFacts) -> Iterator[tuple[Loc, Any, str]]:
    """The vehicle must lift itself and its heaviest payload with some thrust to spare for control (our FMU:
    its parameters are known by name)."""
    if not facts.built_in:
        return
    payload = max((p.mass_kg for p in scenario.payload), default=0.0)
    rotors = facts.mapping.rotor_count
    ratio = thrust_to_weight(scenario_parameters(scenario, facts), rotors, payload)
    if ratio <= 1:
        with_payload = f" with its {payload:g} kg payload" if payload else ""
        yield ("vehicle", "thrust_max"), scenario.vehicle.thrust_max, (
            f"thrust-to-weight {ratio:.2f}: its {rotors} rotors cannot lift the vehicle{with_payload}; "
            "expected above 1 (a larger thrust_max or a smaller mass)")


BATTERY_OUTPUTS = ("battery_voltage", "battery_current", "battery_consumed", "battery_remaining")
BATTERY_FAULT_INPUTS = ("battery_fault_cell", "battery_fault_resistance", "battery_fault_voltage")


def _battery_problems(scenario: Scenario, facts: PlantFacts) -> Iterator[tuple[Loc, Any, str]]:
    """`battery:` needs a plant with battery outputs (and its parameters, and the fault inputs for a failure); our
    FMU's pack must also power the hover at full charge."""
    battery = scenario.battery
    assert battery is not None
    name = facts.mapping.source.name
    missing = [port for port in BATTERY_OUTPUTS if port not in facts.mapping.spec.outputs]
    if missing:
        yield ("battery",), None, (f"the plant mapping {name} gives no battery outputs ({', '.join(missing)}); "
                                   "expected a plant with a battery, or no battery: section")
        return
    for parameter in battery.fmu_parameters(every=False):
        if parameter not in facts.parameters:
            yield ("battery",), None, f"no parameter {parameter!r} in the plant {name}'s FMU for it; expected one"
    if battery.failure is not None and not set(BATTERY_FAULT_INPUTS) <= facts.inputs:
        yield ("battery", "failure"), None, f"the plant mapping {name} gives its FMU no battery fault inputs"
    if facts.built_in:
        parameters = scenario_parameters(scenario, facts)
        payload = max((p.mass_kg for p in scenario.payload), default=0.0)
        needed, most = hover_power_w(parameters, facts.mapping.rotor_count, payload), pack_max_power_w(parameters)
        if needed > most:
            yield ("battery",), None, (
                f"at full charge its {battery.cells} cells deliver at most {most:.0f} W (V²/4R), the hover needs "
                f"{needed:.0f} W; expected more cells or less resistance")
