"""The airframe table against its sources: the FMU's own defaults (the inspection quad) and the paper's §4
numbers, and the plant and the emulator reading the same entry."""

from __future__ import annotations

import numpy as np
import pytest

from firmware_interface.airframes import AIRFRAME_NAMES, AIRFRAMES
from firmware_interface.emulator.config import build_config
from hil.scenario.vehicles import PLANT_PRESETS
from plant_fmu.mapping import default_mapping_path, load_mapping
from plant_fmu.variables import PARAMETER_DEFAULTS


def test_the_inspection_quad_is_the_fmus_default_vehicle():
    quad = PLANT_PRESETS["inspection_quad"]
    airframe_keys = ("mass", "Ixx", "Iyy", "Izz", "arm_length", "thrust_max", "thrust_curve_k", "motor_tau",
                     "rotor_reversible", "yaw_moment_coeff", "drag_coeff_x", "drag_coeff_y", "drag_coeff_z")
    assert {k: quad[k] for k in airframe_keys} == {k: PARAMETER_DEFAULTS[k] for k in airframe_keys}


def test_the_paper_airframe_has_the_papers_numbers():
    # §4: m = 1 kg, l = 0.5 m, Ixx = Iyy = 0.121, Izz = 0.151 kg·m², thrust and torque applied directly
    paper = PLANT_PRESETS["paper_airframe"]
    assert (paper["mass"], paper["arm_length"]) == (1.0, 0.5)
    assert (paper["Ixx"], paper["Iyy"], paper["Izz"]) == (0.121, 0.121, 0.151)
    assert paper["motor_tau"] == 0.0 and paper["thrust_curve_k"] == 0.0 and paper["rotor_reversible"] == 1.0
    assert (paper["drag_coeff_x"], paper["drag_coeff_y"], paper["drag_coeff_z"]) == (0.0, 0.0, 0.0)


@pytest.mark.parametrize("name", AIRFRAME_NAMES)
def test_the_flight_code_believes_the_vehicle_the_plant_flies(name):
    belief, truth = build_config({"airframe": name}).vehicle, PLANT_PRESETS[name]
    assert (belief.mass, belief.Ixx, belief.Iyy, belief.Izz) == (
        truth["mass"], truth["Ixx"], truth["Iyy"], truth["Izz"])
    assert (belief.arm_length, belief.thrust_max, belief.yaw_moment_coeff) == (
        truth["arm_length"], truth["thrust_max"], truth["yaw_moment_coeff"])
    assert belief.thrust_curve_k == truth["thrust_curve_k"] and belief.reversible == bool(truth["rotor_reversible"])
    assert belief.g == PARAMETER_DEFAULTS["g"]


def test_every_airframe_is_offered_by_the_schema_and_the_emulator():
    assert set(AIRFRAMES) == set(PLANT_PRESETS) == set(AIRFRAME_NAMES)


@pytest.mark.parametrize("name", AIRFRAME_NAMES)
def test_the_flight_codes_rotors_are_those_of_our_plant_for_the_airframe(name):
    """The emulator's default mixer (its belief, used when the bench does not send the plant's rotors) and our
    FMU's mapping for the airframe's rotor count (the truth) place and spin the same rotors, in the same order."""
    belief = build_config({"airframe": name}).vehicle
    truth = load_mapping(default_mapping_path(AIRFRAMES[name].rotor_count)).rotor_geometry(
        {"arm_length": PLANT_PRESETS[name]["arm_length"]})
    assert np.array([r.position_frd_m for r in belief.rotors]) == pytest.approx(truth.positions_frd_m, abs=1e-15)
    assert [r.spin == "ccw" for r in belief.rotors] == list(truth.ccw)


def test_the_inspection_hexa_is_the_inspection_quads_body_on_six_rotors():
    assert PLANT_PRESETS["inspection_hexa"] == PLANT_PRESETS["inspection_quad"]
    assert (AIRFRAMES["inspection_hexa"].rotor_count, AIRFRAMES["inspection_quad"].rotor_count) == (6, 4)
