"""Start-up checks of a plant through its mapping, before any board starts: each failure is a
`MappingError` whose lines name the mapping file and the field to look at.

The sign check: resting on the ground an ideal accelerometer reads (0, 0, -g) in FRD, and the attitude turns
that into (0, 0, -g) in NED. A body frame given the wrong way (FLU as FRD) flips the first; an earth frame
given the wrong way (ENU as NED) flips the second.
"""

from __future__ import annotations

from collections.abc import Mapping as MappingType
from pathlib import Path

import numpy as np

from plant_fmu.frames import quat_to_dcm
from plant_fmu.mapping import Mapping, MappingError, load_mapping, problem
from plant_fmu.plant import Plant
from plant_fmu.state import PlantState

REST_TOLERANCE_M_S2 = 0.5  # per axis: a vehicle resting level on flat ground; noise and tilt stay well inside


def _fmt(v: np.ndarray) -> str:
    return "(" + ", ".join(f"{x:+.2f}" for x in v) + ")"


def rest_problems(state: PlantState, gravity: float, source: Path) -> list[str]:
    """What the state at rest says about the mapping's frames and signs (empty: all as expected)."""
    expected = np.array((0.0, 0.0, -gravity))
    force = state.specific_force_frd
    magnitude = float(np.linalg.norm(force))
    if abs(magnitude - gravity) > REST_TOLERANCE_M_S2 or float(np.linalg.norm(state.vel_ned)) > 0.05:
        return [problem(source, "outputs.specific_force",
                        f"the plant does not start at rest: |specific force| = {magnitude:.2f} m/s² (g = "
                        f"{gravity:.2f}), speed {float(np.linalg.norm(state.vel_ned)):.2f} m/s; start it on the "
                        "ground (its initial position parameters) for the start-up check")]
    lines = []
    if np.max(np.abs(force - expected)) > REST_TOLERANCE_M_S2:
        lines.append(problem(source, "outputs.specific_force",
                             f"at rest it reads {_fmt(force)} m/s² in FRD, an accelerometer at rest reads "
                             f"{_fmt(expected)}: is the body frame FLU given as FRD (frames.body), or the sign "
                             "of the specific force reversed?"))
    earth, down = quat_to_dcm(state.q_wxyz) @ force, np.array((0.0, 0.0, gravity))
    if np.max(np.abs(earth - expected)) > REST_TOLERANCE_M_S2:
        lines.append(problem(source, "frames.earth",
                             f"at rest the attitude turns the specific force into {_fmt(earth)} m/s² NED, gravity "
                             f"is {_fmt(down)} down: is an ENU earth frame given as NED, or the attitude's "
                             "order or direction (order, rotates) wrong?"))
    return lines


def check_at_rest(plant: Plant) -> None:
    """The sign check on a plant just built (t = 0, rotors stopped, resting on the ground)."""
    mapping = plant.resolved.mapping
    lines = rest_problems(plant.state(), mapping.spec.gravity_m_s2, mapping.source)
    if lines:
        raise MappingError(lines)


def check_rotor_count(mapping: Mapping, airframe_rotors: int, airframe: str) -> None:
    """The mapped rotors must be the airframe's: the board mixes for its own count."""
    if mapping.rotor_count != airframe_rotors:
        raise MappingError([problem(mapping.source, "rotors.list",
                                    f"{mapping.rotor_count} rotors mapped, the board's airframe {airframe} has "
                                    f"{airframe_rotors}")])


def check_plant(mapping: Mapping | Path | None = None, parameters: MappingType[str, float] | None = None,
                airframe_rotors: tuple[int, str] | None = None) -> Mapping:
    """Every check `hil check` makes on a plant: the mapping file, its names against the FMU, the rotor
    count against the airframe's (count, name), and the sign check on an instance at rest."""
    mapping = mapping if isinstance(mapping, Mapping) else load_mapping(mapping)
    if airframe_rotors is not None:
        check_rotor_count(mapping, *airframe_rotors)
    with Plant(parameters, mapping=mapping) as plant:
        check_at_rest(plant)
    return mapping
