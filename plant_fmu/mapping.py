"""The mapping file: which variable of an FMU serves each port of the plant contract, in what unit and frame.

Loading checks what the file alone can tell (its structure, units known and of the port's quantity, sizes,
the rotor geometry); `plant_fmu.resolve` then checks it against the FMU's modelDescription.xml. Every
problem is one line naming the file and the field (`MappingError`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, ValidationInfo, field_validator

from plant_fmu.contract import ANY_COUNT, ATTITUDE_PORTS, INPUT_PORTS, OUTPUT_PORTS, PER_ROTOR, PORTS, Port
from plant_fmu.frames import BodyFrame, EarthFrame
from plant_fmu.units import UnitError, si_factor

MAPPINGS_DIR = Path(__file__).parent / "mappings"
BUILT_IN = "built-in"  # `fmu: built-in`: the FMU this project builds (hil fmu build)
# ports named under `inputs:` and `outputs:` (the per-rotor ones are named in the rotor list)
INPUT_PORT_NAMES = tuple(p.name for p in INPUT_PORTS if p.size > 0)
OUTPUT_PORT_NAMES = tuple(p.name for p in OUTPUT_PORTS if p.size != PER_ROTOR)
Finite = Annotated[float, Field(allow_inf_nan=False)]


class MappingError(ValueError):
    """A mapping that cannot drive its FMU: one line per problem, each naming the file and the field."""

    def __init__(self, lines: list[str]) -> None:
        super().__init__("\n".join(lines))
        self.lines = tuple(lines)


def problem(source: Path | str, field: str, reason: str) -> str:
    return f"{source}: {field}: {reason}"


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class PortMap(_Model):
    """The FMU variables of one port: `variables` (several) or `variable` (one)."""

    variables: tuple[str, ...] | None = None
    variable: str | None = None
    unit: str = "1"
    order: Literal["wxyz", "xyzw"] = "wxyz"  # quaternion component order
    rotates: Literal["body_to_earth", "earth_to_body"] = "body_to_earth"  # what the quaternion turns into what
    sequence: Literal["ZYX"] = "ZYX"  # Euler angles: yaw, then pitch, then roll

    @property
    def names(self) -> tuple[str, ...]:
        return self.variables if self.variables is not None else ((self.variable,) if self.variable else ())


class Rotor(_Model):
    """One rotor, in PX4's motor order: its variables and where it sits (FRD, seen from above for `spin`)."""

    command: str
    health: str | None = None
    thrust: str | None = None
    speed: str | None = None
    azimuth_deg: Finite | None = None  # from the nose towards the right, at the arm length
    position_frd_m: tuple[Finite, Finite, Finite] | None = None
    spin: Literal["ccw", "cw"]


class Rotors(_Model):
    arm_length_m: Annotated[float, Field(gt=0, allow_inf_nan=False)] | None = None
    arm_length_parameter: str | None = None  # or the FMU parameter that holds it
    command_range: tuple[Finite, Finite] = (0.0, 1.0)  # the FMU's values for the bench's 0 and 1
    thrust_unit: str = "N"
    speed_unit: str = "rad/s"
    list: Annotated[tuple[Rotor, ...], Field(min_length=1, max_length=12)]


class Frames(_Model):
    earth: EarthFrame
    body: BodyFrame


class HeadingParameter(_Model):
    """The FMU parameter that sets the vehicle's heading at rest at the start, in the FMU's earth frame (NED: from
    north towards east; ENU: from east towards north), so that it waits facing the mission's first heading."""

    parameter: str
    unit: str = "rad"


class MappingFile(_Model):
    fmu: str
    frames: Frames
    step_s: Annotated[float, Field(gt=0, allow_inf_nan=False)] | None = None  # None: any step the bench takes
    gravity_m_s2: Annotated[float, Field(gt=0, allow_inf_nan=False)] = 9.80665
    parameters: dict[str, float | bool] = {}
    initial_heading: HeadingParameter | None = None  # None: the vehicle starts at the FMU's own heading
    rotors: Rotors
    inputs: dict[str, PortMap] = {}
    outputs: dict[str, PortMap]

    @field_validator("inputs", "outputs")
    @classmethod
    def _known_ports(cls, ports: dict[str, PortMap], info: ValidationInfo) -> dict[str, PortMap]:
        known = INPUT_PORT_NAMES if info.field_name == "inputs" else OUTPUT_PORT_NAMES
        unknown = [name for name in ports if name not in known]
        if unknown:
            raise ValueError(f"no port {unknown[0]!r} in the plant contract; {info.field_name}: {', '.join(known)}")
        return ports


@dataclass(frozen=True)
class RotorGeometry:
    """Where the rotors sit and which way they turn, in PX4's motor order: what the mixer and PX4's
    control allocation (CA_ROTOR*) must match."""

    positions_frd_m: np.ndarray  # (n, 3)
    ccw: tuple[bool, ...]  # seen from above; PX4: CA_ROTORi_KM > 0

    @property
    def count(self) -> int:
        return len(self.ccw)

    def px4_parameters(self, moment_coeff: float = 0.05) -> dict[str, float]:
        """The geometry as PX4's control allocation reads it (CA_ROTOR_COUNT, CA_ROTORi_PX/PY/PZ in metres,
        CA_ROTORi_KM positive for a CCW rotor), to set on a board whose airframe lacks this frame."""
        params: dict[str, float] = {"CA_ROTOR_COUNT": float(self.count)}
        for i, ((x, y, z), ccw) in enumerate(zip(self.positions_frd_m.tolist(), self.ccw, strict=True)):
            params |= {f"CA_ROTOR{i}_PX": x, f"CA_ROTOR{i}_PY": y, f"CA_ROTOR{i}_PZ": z,
                       f"CA_ROTOR{i}_KM": moment_coeff if ccw else -moment_coeff}
        return params


@dataclass(frozen=True)
class Mapping:
    """A checked mapping file and where it came from."""

    source: Path
    spec: MappingFile

    @property
    def rotor_count(self) -> int:
        return len(self.spec.rotors.list)

    def fmu_path(self) -> Path | None:
        """The FMU file, or None for the built-in one."""
        fmu = self.spec.fmu
        return None if fmu == BUILT_IN else (self.source.parent / fmu).resolve()

    def heading_parameters(self, yaw_ned_rad: float) -> dict[str, float]:
        """The parameter that starts the vehicle facing `yaw_ned_rad` (NED, from north), in the FMU's frame and unit;
        none if the mapping names none."""
        heading = self.spec.initial_heading
        if heading is None:
            return {}
        yaw = yaw_ned_rad if self.spec.frames.earth == "NED" else math.remainder(math.pi / 2 - yaw_ned_rad, math.tau)
        factor = si_factor(heading.unit, "angle")
        return {heading.parameter: yaw if factor == 1.0 else yaw / factor}

    def rotor_geometry(self, parameters: dict[str, float] | None = None) -> RotorGeometry:
        """Positions in metres; an arm length named by parameter is read from `parameters`, then the
        mapping's own parameters (`resolve.ResolvedMapping.rotor_geometry` also knows the FMU's start value)."""
        rotors = self.spec.rotors
        arm = rotors.arm_length_m
        if arm is None and rotors.arm_length_parameter is not None:
            known = {**self.spec.parameters, **(parameters or {})}
            arm = float(known[rotors.arm_length_parameter]) if rotors.arm_length_parameter in known else None
        return geometry_of(rotors, arm)


def geometry_of(rotors: Rotors, arm_length_m: float | None) -> RotorGeometry:
    positions = []
    for rotor in rotors.list:
        if rotor.position_frd_m is not None:
            positions.append(rotor.position_frd_m)
        else:
            assert rotor.azimuth_deg is not None and arm_length_m is not None  # checked on loading
            az = math.radians(rotor.azimuth_deg)
            positions.append((arm_length_m * math.cos(az), arm_length_m * math.sin(az), 0.0))
    return RotorGeometry(np.array(positions, dtype=float), tuple(r.spin == "ccw" for r in rotors.list))


def default_mapping_path(rotor_count: int = 4) -> Path:
    """Our own FMU's mapping: quad X, or hexa X with 6 rotors."""
    return MAPPINGS_DIR / {4: "quadrotor_x.yaml", 6: "hexarotor_x.yaml"}[rotor_count]


def load_mapping(path: Path | None = None) -> Mapping:
    """Read and check a mapping file (default: our own quad X FMU's)."""
    path = Path(path) if path is not None else default_mapping_path()
    try:
        raw = yaml.safe_load(path.read_text())
    except OSError as exc:
        raise MappingError([problem(path, "file", f"cannot read it: {exc.strerror or exc}")]) from None
    except yaml.YAMLError as exc:
        raise MappingError([problem(path, "file", f"not YAML: {str(exc).splitlines()[0]}")]) from None
    try:
        spec = MappingFile.model_validate(raw)
    except ValidationError as exc:
        raise MappingError([problem(path, ".".join(str(p) for p in e["loc"]) or "file", e["msg"])
                            for e in exc.errors()]) from None
    lines = [problem(path, field, reason) for field, reason in _content_problems(spec)]
    if lines:
        raise MappingError(lines)
    return Mapping(path, spec)


def _content_problems(spec: MappingFile) -> list[tuple[str, str]]:
    found = [*_rotor_problems(spec.rotors)]
    if spec.initial_heading is not None:
        found += _unit_problem("initial_heading.unit", spec.initial_heading.unit, PORTS["attitude_euler"])
    for group, ports in (("inputs", spec.inputs), ("outputs", spec.outputs)):
        for name, port_map in ports.items():
            found += [(f"{group}.{name}.{field}", reason) for field, reason in _port_problems(PORTS[name], port_map)]
    missing = [p.name for p in OUTPUT_PORTS if p.required and p.size > 0 and p.name not in spec.outputs]
    found += [(f"outputs.{name}", "missing: the bench needs it") for name in missing]
    if not any(name in spec.outputs for name in ATTITUDE_PORTS):
        found.append(("outputs", f"no attitude: map {ATTITUDE_PORTS[0]} or {ATTITUDE_PORTS[1]}"))
    return found


def _port_problems(port: Port, port_map: PortMap) -> list[tuple[str, str]]:
    names = port_map.names
    if port_map.variables is not None and port_map.variable is not None:
        return [("variable", "give `variable` or `variables`, not both")]
    if port.size != ANY_COUNT and len(names) != port.size:
        key = "variable" if port.size == 1 else "variables"
        return [(key, f"{port.name} needs {port.size} variable(s), {len(names)} given")]
    if not names:
        return [("variables", "no variable given")]
    if port.quantity == "boolean":
        return []
    return _unit_problem("unit", port_map.unit, port)


def _unit_problem(field: str, unit: str, port: Port) -> list[tuple[str, str]]:
    try:
        si_factor(unit, port.quantity)
    except UnitError as exc:
        return [(field, str(exc))]
    return []


def _rotor_problems(rotors: Rotors) -> list[tuple[str, str]]:
    found = _unit_problem("rotors.thrust_unit", rotors.thrust_unit, PORTS["rotor_thrust"])
    found += _unit_problem("rotors.speed_unit", rotors.speed_unit, PORTS["rotor_speed"])
    for key in ("health", "thrust", "speed"):
        given = [getattr(r, key) is not None for r in rotors.list]
        if any(given) and not all(given):
            found.append((f"rotors.list[{given.index(False)}].{key}", f"every rotor or none names its {key}"))
    has_arm = rotors.arm_length_m is not None or rotors.arm_length_parameter is not None
    for i, rotor in enumerate(rotors.list):
        if (rotor.azimuth_deg is None) == (rotor.position_frd_m is None):
            found.append((f"rotors.list[{i}]", "give its azimuth_deg (with the rotors' arm length) or its "
                                               "position_frd_m, one of them"))
        elif rotor.azimuth_deg is not None and not has_arm:
            found.append((f"rotors.list[{i}].azimuth_deg", "needs rotors.arm_length_m or arm_length_parameter"))
    low, high = rotors.command_range
    if low == high:
        found.append(("rotors.command_range", "the FMU's values for command 0 and 1 must differ"))
    return found

