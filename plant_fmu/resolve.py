"""A mapping checked against its FMU's modelDescription.xml: every variable found by name, with the
causality, type and unit its port needs, and its value reference taken from the FMU itself."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from fmpy import read_model_description

from plant_fmu.contract import PORTS, ROTOR_KEYS, Port
from plant_fmu.mapping import Mapping, MappingError, PortMap, RotorGeometry, geometry_of, problem
from plant_fmu.units import UNITS, si_factor

REAL_TYPES = ("Real", "Float64")  # FMI 2.0, FMI 3.0
PARAMETER_CAUSALITIES = ("parameter", "structuralParameter")
SETTABLE_TYPES = (*REAL_TYPES, "Integer", "Int32", "Int64", "Boolean")


@dataclass(frozen=True)
class ResolvedPort:
    """A port's FMU variables and the factor that turns their unit into SI."""

    port: Port
    names: tuple[str, ...]
    vrs: tuple[int, ...]
    factor: float
    spec: PortMap | None  # the mapping's entry (None for ports named in the rotor list)


@dataclass(frozen=True)
class ResolvedMapping:
    mapping: Mapping
    fmu_path: Path
    fmi_version: str  # "2.0" or "3.0"
    model_identifier: str
    token: str  # FMI 2.0 guid, FMI 3.0 instantiation token
    inputs: dict[str, ResolvedPort]
    outputs: dict[str, ResolvedPort]
    variables: dict[str, Any]  # every model variable by name (fmpy's ModelVariable)

    def rotor_geometry(self, parameters: dict[str, float] | None = None) -> RotorGeometry:
        """The mapped rotors' geometry; an arm length named by parameter comes from `parameters`, the
        mapping's own parameters, or the FMU's start value."""
        rotors = self.mapping.spec.rotors
        arm = rotors.arm_length_m
        if arm is None and rotors.arm_length_parameter is not None:
            name = rotors.arm_length_parameter
            known = {**self.mapping.spec.parameters, **(parameters or {})}
            arm = float(known[name]) if name in known else float(self.variables[name].start)
        return geometry_of(rotors, arm)


def resolve(mapping: Mapping, fmu_path: Path) -> ResolvedMapping:
    """Check `mapping` against the FMU at `fmu_path` and resolve its names; MappingError lists every problem."""
    source = mapping.source
    try:
        description = read_model_description(str(fmu_path))
    except Exception as exc:  # fmpy raises plain exceptions for a missing or broken file
        raise MappingError([problem(source, "fmu", f"cannot read {fmu_path}: {exc}")]) from None
    if description.fmiVersion[0] not in "23":
        raise MappingError([problem(source, "fmu", f"{fmu_path.name} is FMI {description.fmiVersion}: the bench "
                                                   "steps FMI 2.0 and 3.0 co-simulation FMUs")])
    if description.coSimulation is None:
        raise MappingError([problem(source, "fmu", f"{fmu_path.name} has no co-simulation interface")])
    variables = {v.name: v for v in description.modelVariables}
    resolver = _Resolver(mapping, fmu_path.name, variables)
    inputs, outputs = resolver.ports("input"), resolver.ports("output")
    resolver.check_parameters()
    if resolver.lines:
        raise MappingError(resolver.lines)
    return ResolvedMapping(mapping, fmu_path, description.fmiVersion, description.coSimulation.modelIdentifier,
                           description.guid, inputs, outputs, variables)


class _Resolver:
    """Looks every name up once and collects one line per problem."""

    def __init__(self, mapping: Mapping, fmu_name: str, variables: dict[str, Any]) -> None:
        self.mapping, self.fmu_name, self.variables = mapping, fmu_name, variables
        self.lines: list[str] = []

    def _problem(self, field: str, reason: str) -> None:
        self.lines.append(problem(self.mapping.source, field, reason))

    def _variable(self, field: str, name: str, causalities: tuple[str, ...], types: tuple[str, ...]) -> Any:
        variable = self.variables.get(name)
        if variable is None:
            self._problem(field, f"no variable {name!r} in {self.fmu_name}'s modelDescription.xml")
        elif variable.causality not in causalities:
            self._problem(field, f"{name!r} is {_article(variable.causality)} of {self.fmu_name}, this port "
                                 f"needs {_article(causalities[0])}")
        elif variable.type not in types:
            self._problem(field, f"{name!r} is of type {variable.type}, this port needs {' or '.join(types)}")
        else:
            return variable
        return None

    def _port(self, port: Port, field: str, names: tuple[str, ...], unit: str, spec: PortMap | None) -> ResolvedPort:
        types = ("Boolean",) if port.quantity == "boolean" else REAL_TYPES
        found = [self._variable(f"{field}[{i}]" if len(names) > 1 else field, name, (port.direction,), types)
                 for i, name in enumerate(names)]
        for variable in found:
            declared = getattr(variable, "unit", None) or getattr(getattr(variable, "declaredType", None), "unit", None)
            if variable is not None and declared in UNITS and unit in UNITS and UNITS[declared] != UNITS[unit]:
                self._problem(field, f"{variable.name!r} is in {declared} in {self.fmu_name}, the mapping says {unit}")
                break  # one line for the port
        factor = 1.0 if port.quantity == "boolean" else si_factor(unit, port.quantity)
        vrs = tuple(v.valueReference if v is not None else -1 for v in found)
        return ResolvedPort(port, names, vrs, factor, spec)

    def ports(self, direction: str) -> dict[str, ResolvedPort]:
        spec = self.mapping.spec
        resolved: dict[str, ResolvedPort] = {}
        rotor_units = {"rotor_thrust": spec.rotors.thrust_unit, "rotor_speed": spec.rotors.speed_unit}
        for key, port_name in ROTOR_KEYS.items():
            port = PORTS[port_name]
            names = tuple(getattr(r, key) for r in spec.rotors.list)
            if port.direction == direction and all(names):
                resolved[port_name] = self._port(port, f"rotors.list.{key}", names,
                                                 rotor_units.get(port_name, "1"), None)
        group = spec.inputs if direction == "input" else spec.outputs
        for name, port_map in group.items():
            resolved[name] = self._port(PORTS[name], f"{direction}s.{name}", port_map.names, port_map.unit, port_map)
        return resolved

    def check_parameters(self) -> None:
        spec = self.mapping.spec
        for name in spec.parameters:
            self._variable(f"parameters.{name}", name, PARAMETER_CAUSALITIES, SETTABLE_TYPES)
        if spec.initial_heading is not None:
            self._variable("initial_heading.parameter", spec.initial_heading.parameter, PARAMETER_CAUSALITIES,
                           REAL_TYPES)
        if spec.rotors.arm_length_parameter is not None:
            self._variable("rotors.arm_length_parameter", spec.rotors.arm_length_parameter, PARAMETER_CAUSALITIES,
                           REAL_TYPES)


def _article(causality: str) -> str:
    return ("an " if causality[0] in "aeiou" else "a ") + causality
