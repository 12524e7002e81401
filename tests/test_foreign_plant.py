"""A plant from another exporter: the quadrotor of tests/data/foreign_plant/enu_quadrotor.py (its own
equations, names, ENU/FLU frames, degrees, rpm, PWM, Heun at 2 ms), exported by pythonfmu as an FMI 2.0
co-simulation FMU, flies through its mapping file only, and agrees with our C FMU on the same inputs."""

from __future__ import annotations

import copy
import math
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from plant_fmu import Plant, PlantState
from plant_fmu.checks import check_plant, check_rotor_count
from plant_fmu.mapping import MappingError

SOURCE = Path(__file__).parent / "data" / "foreign_plant"
Z = np.zeros(3)


def fly(plant: Plant, schedule: list[tuple[float, tuple[float, ...]]],
        wind_ned: tuple[float, float, float] = (1.0, -0.5, 0.0)) -> list[PlantState]:
    """Rotor commands (PX4's order) held for each duration in a steady wind; the state every 0.1 s."""
    states = []
    for seconds, commands in schedule:
        for k in range(round(seconds / 0.004)):
            plant.set_input_groups(commands, (1.0,) * 4, np.array(wind_ned), Z, Z, 0.0)
            plant.step(0.004)
            if (k + 1) % 25 == 0:
                states.append(plant.state())
    return states


# Climb, then an uneven 0.3 s (rotor 1 front-right and 4 rear-right less than 2 and 3: it rolls right and
# keeps rolling), then equal commands: a tumbling flight that exercises every term and the Euler conversion.
MANOEUVRE = [(1.0, (0.7, 0.7, 0.7, 0.7)), (0.3, (0.66, 0.72, 0.71, 0.68)), (0.7, (0.66, 0.66, 0.66, 0.66))]


def test_it_loads_through_its_mapping_and_passes_the_start_up_checks(foreign_mapping):
    mapping = check_plant(foreign_mapping)
    assert mapping.rotor_count == 4
    with Plant(mapping=foreign_mapping) as plant:
        state = plant.state()
        assert plant.resolved.fmi_version == "2.0"
        # the FMU's nose points east (ENU yaw 0): 90° in NED
        assert state.rpy[2] == pytest.approx(math.pi / 2, abs=1e-12) and state.on_ground


def test_open_loop_it_flies_as_our_fmu_does(foreign_mapping):
    """Same vehicle, same inputs (commands, a NED wind), both from rest facing east. They differ by their
    integrators (Heun at 2 ms against RK4 at 1 ms: a second-order method's error on the 20 ms rotor lag) and
    by nothing else. Along this 2 s open-loop flight, which tumbles past 90° of roll, they agree within 0.4 mm
    and 0.0002° here; the bounds leave a factor of 5 to 60 for another machine's libm and numpy."""
    with Plant(mapping=foreign_mapping) as plant:
        theirs = fly(plant, MANOEUVRE)
    with Plant({"init_yaw": math.pi / 2}) as plant:
        ours = fly(plant, MANOEUVRE)
    assert -ours[-1].pos_ned[2] > 1.0 and abs(ours[-1].rpy[0]) > math.radians(5)  # it climbed and banked
    for a, b in zip(theirs, ours, strict=True):
        assert np.max(np.abs(a.pos_ned - b.pos_ned)) < 2e-3
        assert np.max(np.abs(a.vel_ned - b.vel_ned)) < 2e-3
        assert np.degrees(np.max(np.abs(a.rpy - b.rpy))) < 0.01
        assert np.degrees(np.max(np.abs(a.rates_frd - b.rates_frd))) < 0.03
        assert np.max(np.abs(a.specific_force_frd - b.specific_force_frd)) < 5e-3
        assert a.thrusts_n == pytest.approx(b.thrusts_n, rel=5e-4)
        assert a.rotor_speeds_rad_s == pytest.approx(b.rotor_speeds_rad_s, rel=5e-4)  # their rpm, as rad/s


def _variant(foreign_mapping: Path, edit) -> Path:
    spec: dict[str, Any] = yaml.safe_load(foreign_mapping.read_text())
    spec = copy.deepcopy(spec)
    edit(spec)
    path = foreign_mapping.with_name("wrong.yaml")
    path.write_text(yaml.safe_dump(spec))
    return path


WRONG = {
    "missing name": (lambda s: s["outputs"]["position"].update(variables=["x_e", "y_n", "z_up"]),
                     "outputs.position[2]: no variable 'z_up' in EnuQuadrotor.fmu's modelDescription.xml"),
    "input where an output is needed": (lambda s: s["outputs"]["velocity"].update(variables=["wind_e", "v_n", "v_u"]),
                                        "outputs.velocity[0]: 'wind_e' is an input of EnuQuadrotor.fmu, this port "
                                        "needs an output"),
    "unit typo": (lambda s: s["outputs"]["attitude_euler"].update(unit="degs"),
                  "outputs.attitude_euler.unit: unknown unit 'degs'"),
    "ENU given as NED": (lambda s: s["frames"].update(earth="NED"),
                         "frames.earth: at rest the attitude turns the specific force into (+0.00, +0.00, +9.81)"),
    "FLU given as FRD": (lambda s: s["frames"].update(body="FRD"),
                         "outputs.specific_force: at rest it reads (+0.00, +0.00, +9.81) m/s² in FRD"),
}


@pytest.mark.parametrize("case", WRONG, ids=str)
def test_each_wrong_mapping_of_it_is_one_line(foreign_mapping, case):
    edit, expected = WRONG[case]
    path = _variant(foreign_mapping, edit)
    with pytest.raises(MappingError) as caught:
        check_plant(path)
    assert len(caught.value.lines) == 1 and caught.value.lines[0].startswith(f"{path}: "), caught.value.lines
    assert expected in caught.value.lines[0], caught.value.lines[0]


def test_its_four_rotors_against_a_hexa_airframe_is_one_line(foreign_mapping):
    with pytest.raises(MappingError) as caught:
        check_plant(foreign_mapping, airframe_rotors=(6, "hexa_x"))
    assert caught.value.lines == (f"{foreign_mapping}: rotors.list: 4 rotors mapped, the board's airframe hexa_x "
                                  "has 6",)
    check_rotor_count(check_plant(foreign_mapping), 4, "quad_x")


@pytest.fixture(scope="session")
def fmi3_mapping(tmp_path_factory) -> Path:
    """An FMI 3.0 co-simulation FMU built by pythonfmu3, with its mapping beside it."""
    from pythonfmu3.builder import FmuBuilder

    out = tmp_path_factory.mktemp("fmi3_plant")
    FmuBuilder.build_FMU(SOURCE / "vertical_lift_fmi3.py", dest=out)
    shutil.copy(SOURCE / "vertical_lift_fmi3.yaml", out)
    return out / "vertical_lift_fmi3.yaml"


def test_an_fmi3_plant_steps_through_its_mapping(fmi3_mapping):
    """fmpy's FMI 3.0 calls (fmi3SetFloat64, fmi3DoStep, fmi3GetFloat64) on the plant's hot path: four rotors
    at 0.6 lift 1 kg with 12 N, so after 1 s it is (12/1 - g)/2 m up, exactly (constant acceleration)."""
    check_plant(fmi3_mapping)
    with Plant(mapping=fmi3_mapping) as plant:
        assert plant.resolved.fmi_version == "3.0"
        fly(plant, [(1.0, (0.6,) * 4)], wind_ned=(0.0, 0.0, 0.0))  # it has no wind input
        state = plant.state()
    assert state.pos_ned == pytest.approx((0.0, 0.0, -(12.0 - 9.80665) / 2), abs=1e-9)
    assert state.vel_ned == pytest.approx((0.0, 0.0, -(12.0 - 9.80665)), abs=1e-9)
    assert state.specific_force_frd == pytest.approx((0.0, 0.0, -12.0), abs=1e-12)
    assert state.q_wxyz == pytest.approx((math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5)), abs=1e-12)  # nose east
    assert math.isnan(state.thrust_total_n) and state.battery is None  # not mapped: not invented
