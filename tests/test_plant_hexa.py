"""Our FMU as PX4's hexa X (rotor_count 6, plant_fmu/mappings/hexarotor_x.yaml): the geometry is PX4's,
each rotor pushes and yaws the way its place and spin say, and health acts per rotor."""

from __future__ import annotations

import math
import os
import re
import tarfile
from pathlib import Path

import numpy as np
import pytest

from plant_fmu import Plant, PlantError
from plant_fmu.checks import check_plant
from plant_fmu.mapping import Mapping, default_mapping_path, load_mapping
from plant_fmu.variables import PARAMETER_DEFAULTS as DEFAULTS

HEXA = default_mapping_path(6)
# PX4 v1.15.4 ROMFS/px4fmu_common/init.d/airframes/6001_hexa_x: CA_ROTORi_PX, PY (m), KM (unset: 0.05, CCW)
PX4_HEXA_X = [(0.0, 0.5, -0.05), (0.0, -0.5, 0.05), (0.43, -0.25, -0.05), (-0.43, 0.25, 0.05),
              (0.43, 0.25, 0.05), (-0.43, -0.25, -0.05)]
Z = np.zeros(3)


def _px4_file_geometry() -> list[tuple[float, float, float]] | None:
    """The same numbers read from the shipped PX4 SITL package, when HIL_PX4_DIR has it."""
    packages = sorted(Path(os.environ.get("HIL_PX4_DIR", "/nonexistent")).glob("px4-sitl-*.tar.gz"))
    if not packages:
        return None
    with tarfile.open(packages[0]) as tar:
        member = next(m for m in tar.getmembers() if m.name.endswith("etc/init.d/airframes/6001_hexa_x"))
        text = tar.extractfile(member).read().decode()  # type: ignore[union-attr]
    values = dict(re.findall(r"param set-default (CA_ROTOR\d_\w+) (\S+)", text))
    return [(float(values.get(f"CA_ROTOR{i}_PX", 0)), float(values.get(f"CA_ROTOR{i}_PY", 0)),
             float(values.get(f"CA_ROTOR{i}_KM", 0.05))) for i in range(6)]


def test_the_hexa_mapping_is_px4s_hexa_x():
    geometry = load_mapping(HEXA).rotor_geometry({"arm_length": 0.5})
    from_file = _px4_file_geometry()
    for reference in (PX4_HEXA_X, *([from_file] if from_file else [])):
        for (x, y, _), (px, py, km), ccw in zip(geometry.positions_frd_m, reference, geometry.ccw, strict=True):
            assert math.atan2(y, x) == pytest.approx(math.atan2(py, px), abs=math.radians(0.5))  # PX4 rounds 0.433
            assert ccw == (km > 0)
    params = geometry.px4_parameters()
    assert params["CA_ROTOR_COUNT"] == 6 and params["CA_ROTOR2_KM"] == -0.05 and params["CA_ROTOR1_KM"] == 0.05


def test_the_hexa_hovers_on_six_equal_commands_from_the_closed_form():
    """u from T = mg/6 = T_max((1-k)u + ku^2): the vehicle holds its place, torques cancel."""
    t_each, k = DEFAULTS["mass"] * DEFAULTS["g"] / 6, DEFAULTS["thrust_curve_k"]
    u = (-(1 - k) + math.sqrt((1 - k) ** 2 + 4 * k * t_each / DEFAULTS["thrust_max"])) / (2 * k)
    trim = {**{f"motor_cmd_{i}": u for i in range(1, 7)}, **{f"motor_health_{i}": 1.0 for i in range(1, 7)}}
    with Plant({"init_pos_d": -10.0, **trim}, mapping=HEXA) as plant:  # inputs before initialisation: in trim
        for _ in range(500):
            plant.set_input_groups((u,) * 6, (1.0,) * 6, Z, Z, Z, 0.0)
            plant.step(0.004)
        state = plant.state()
    assert state.thrust_total_n == pytest.approx(DEFAULTS["mass"] * DEFAULTS["g"], rel=1e-12)
    assert np.max(np.abs(state.pos_ned - (0.0, 0.0, -10.0))) < 1e-9
    assert np.max(np.abs(state.torque_frd)) < 1e-12


@pytest.mark.parametrize("rotor", range(6))
def test_each_rotor_pushes_and_yaws_as_its_place_and_spin_say(rotor):
    """One rotor alone: torque = r x (0, 0, -T) + spin * k_m * T (FRD; a CCW rotor yaws the body right),
    with r at PX4's azimuth and the arm length, computed here from PX4's numbers."""
    px, py, km = PX4_HEXA_X[rotor]
    arm, k_m = DEFAULTS["arm_length"], DEFAULTS["yaw_moment_coeff"]
    x, y = arm * px / math.hypot(px, py), arm * py / math.hypot(px, py)
    commands = tuple(0.5 if i == rotor else 0.0 for i in range(6))
    with Plant({"init_pos_d": -10.0, "motor_tau": 0.0}, mapping=HEXA) as plant:
        plant.set_input_groups(commands, (1.0,) * 6, Z, Z, Z, 0.0)
        plant.step(0.004)
        state = plant.state()
    thrust = state.thrusts_n[rotor]
    assert thrust > 1.0 and np.count_nonzero(state.thrusts_n) == 1
    expected = (-y * thrust, x * thrust, math.copysign(k_m, km) * thrust)
    assert state.torque_frd == pytest.approx(expected, rel=0.01, abs=1e-12)  # PX4 writes 0.43 for 0.5·√3/2


def test_a_failed_rotor_gives_no_thrust_and_the_others_keep_theirs():
    with Plant({"init_pos_d": -10.0, "motor_tau": 0.0}, mapping=HEXA) as plant:
        plant.set_input_groups((0.6,) * 6, (1.0, 1.0, 1.0, 0.0, 1.0, 1.0), Z, Z, Z, 0.0)
        plant.step(0.004)
        thrusts = plant.state().thrusts_n
    assert thrusts[3] == 0.0 and np.all(thrusts[[0, 1, 2, 4, 5]] == thrusts[0]) and thrusts[0] > 0


def test_the_rotor_count_is_the_mappings_and_only_four_or_six():
    with pytest.raises(PlantError, match=r"rotor_count fixed by the plant mapping hexarotor_x\.yaml"):
        Plant({"rotor_count": 4}, mapping=HEXA)
    quad = load_mapping()
    five = Mapping(quad.source, quad.spec.model_copy(update={"parameters": {"rotor_count": 5.0}}))
    with pytest.raises(PlantError, match=r"rotor_count must be 4 \(quad X\) or 6 \(hexa X\)"):
        Plant(mapping=five)
    assert check_plant(HEXA).rotor_count == 6
