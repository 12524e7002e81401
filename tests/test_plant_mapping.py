"""The plant contract through a mapping file: names resolved from the FMU's own modelDescription.xml, and
every way to get a mapping wrong is one line naming the file and the field, before anything flies."""

from __future__ import annotations

import copy
import xml.etree.ElementTree as ET
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from plant_fmu import Plant, PlantError
from plant_fmu.checks import check_plant, check_rotor_count
from plant_fmu.mapping import MappingError, default_mapping_path, load_mapping

DEFAULT = yaml.safe_load(default_mapping_path().read_text())


def variant(tmp_path: Path, edit: Callable[[dict[str, Any]], None], name: str = "variant.yaml") -> Path:
    spec = copy.deepcopy(DEFAULT)
    edit(spec)
    path = tmp_path / name
    path.write_text(yaml.safe_dump(spec))
    return path


def test_value_references_come_from_the_fmus_model_description(fmu_path):
    with zipfile.ZipFile(fmu_path) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    from_xml = {v.get("name"): int(v.get("valueReference")) for v in root.iter("ScalarVariable")}
    with Plant({}, fmu_path) as plant:
        resolved = {**plant.resolved.inputs, **plant.resolved.outputs}
        pairs = [(name, vr) for port in resolved.values() for name, vr in zip(port.names, port.vrs, strict=True)]
    assert len(pairs) >= 50
    assert all(from_xml[name] == vr for name, vr in pairs)


def _set(path: str, value: Any) -> Callable[[dict[str, Any]], None]:
    """An edit that sets one field, by a dotted path with list indices."""
    def edit(spec: dict[str, Any]) -> None:
        *parents, last = path.split(".")
        node: Any = spec
        for key in parents:
            node = node[int(key)] if isinstance(node, list) else node[key]
        if value is None:
            del node[last]
        elif isinstance(node, list):
            node[int(last)] = value
        else:
            node[last] = value
    return edit


WRONG_MAPPINGS = {
    "missing name": (_set("outputs.position.variables.1", "pos_x"),
                     "outputs.position[1]: no variable 'pos_x' in Quadrotor.fmu's modelDescription.xml"),
    "input where an output is needed": (_set("outputs.velocity.variables.0", "wind_n"),
                                        "outputs.velocity[0]: 'wind_n' is an input of Quadrotor.fmu, this port "
                                        "needs an output"),
    "output where an input is needed": (_set("inputs.payload_mass.variable", "total_mass"),
                                        "inputs.payload_mass: 'total_mass' is an output of Quadrotor.fmu, this port "
                                        "needs an input"),
    "unit typo": (_set("outputs.position.unit", "mm/"), "outputs.position.unit: unknown unit 'mm/'"),
    "unit of another quantity": (_set("outputs.body_rates.unit", "m/s"),
                                 "outputs.body_rates.unit: unit 'm/s' measures speed, this port needs angular rate"),
    "unit the FMU contradicts": (_set("outputs.position.unit", "ft"),
                                 "outputs.position: 'pos_n' is in m in Quadrotor.fmu, the mapping says ft"),
    "a real where a boolean is needed": (_set("outputs.on_ground.variable", "thrust_total"),
                                         "outputs.on_ground: 'thrust_total' is of type Real, this port needs "
                                         "Boolean"),
    "required output left out": (_set("outputs.specific_force", None),
                                 "outputs.specific_force: missing: the bench needs it"),
    "port name typo": (_set("outputs.positon", {"variables": ["pos_n", "pos_e", "pos_d"], "unit": "m"}),
                       "outputs: Value error, no port 'positon' in the plant contract"),
    "too few variables": (_set("inputs.wind.variables", ["wind_n", "wind_e"]),
                          "inputs.wind.variables: wind needs 3 variable(s), 2 given"),
    "unknown parameter": (_set("parameters", {"no_such_parameter": 1.0}),
                          "parameters.no_such_parameter: no variable 'no_such_parameter'"),
    "an output set as a parameter": (_set("parameters", {"pos_n": 1.0}),
                                     "parameters.pos_n: 'pos_n' is an output of Quadrotor.fmu, this port needs a "
                                     "parameter"),
    "rotor with no place": (_set("rotors.list.0.azimuth_deg", None), "rotors.list[0]: give its azimuth_deg"),
}


@pytest.mark.parametrize("case", WRONG_MAPPINGS, ids=str)
def test_each_wrong_mapping_is_one_line_naming_file_and_field(case, tmp_path):
    edit, expected = WRONG_MAPPINGS[case]
    path = variant(tmp_path, edit)
    with pytest.raises(MappingError) as caught:
        check_plant(path)
    assert len(caught.value.lines) == 1, caught.value.lines
    line = caught.value.lines[0]
    assert line.startswith(f"{path}: ") and expected in line, line


def test_a_rotor_count_that_disagrees_with_the_airframe_is_one_line():
    with pytest.raises(MappingError) as caught:
        check_rotor_count(load_mapping(), 6, "hexa_x (PX4 6001)")
    assert caught.value.lines == (f"{default_mapping_path()}: rotors.list: 4 rotors mapped, the board's airframe "
                                  "hexa_x (PX4 6001) has 6",)


@pytest.mark.parametrize(("frames", "field", "reads"), [
    ({"earth": "NED", "body": "FLU"}, "outputs.specific_force", "(+0.00, +0.00, +9.81) m/s² in FRD"),
    ({"earth": "ENU", "body": "FRD"}, "frames.earth", "(+0.00, +0.00, +9.81) m/s² NED"),
])
def test_the_sign_check_at_rest_catches_a_frame_given_the_wrong_way(tmp_path, frames, field, reads):
    """Our NED/FRD FMU declared FLU (or ENU): at rest the accelerometer must read -g along down, and the
    attitude must turn it into -g along NED down; the wrong frame flips the sign."""
    path = variant(tmp_path, _set("frames", frames))
    with pytest.raises(MappingError) as caught:
        check_plant(path)
    assert len(caught.value.lines) == 1
    assert caught.value.lines[0].startswith(f"{path}: {field}: at rest") and reads in caught.value.lines[0]


def test_the_sign_check_needs_the_plant_at_rest():
    with pytest.raises(MappingError, match=r"does not start at rest: \|specific force\| = 0\.00 m/s²"):
        check_plant(parameters={"init_pos_d": -100.0})  # in free fall: the accelerometer reads nothing


def test_the_default_mapping_passes_every_check():
    assert check_plant().rotor_count == 4


def test_an_fmu_step_shorter_than_the_benchs_is_taken_as_substeps(tmp_path):
    """step_s 1 ms: four doSteps a 4 ms bench step, the same flight as one 4 ms doStep (the FMU integrates
    1 ms RK4 steps either way); a bench step that is no multiple of it is refused."""
    path = variant(tmp_path, _set("step_s", 0.001))
    flights = []
    for mapping in (None, path):
        with Plant({"init_pos_d": -10.0}, mapping=mapping) as plant:
            for _ in range(50):
                plant.set_input_groups((0.6, 0.62, 0.6, 0.58), (1.0,) * 4, np.array((1.0, 2.0, 0.0)), np.zeros(3),
                                       np.zeros(3), 0.0)
                plant.step(0.004)
            flights.append(plant.outputs().copy())
            assert plant.t == pytest.approx(0.2, abs=1e-12)
    assert np.array_equal(*flights)
    with Plant(mapping=path) as plant, pytest.raises(PlantError, match="not a multiple of the plant's step"):
        plant.step(0.0025)


def test_an_input_the_mapping_lacks_is_refused_when_the_scenario_sets_it(tmp_path):
    path = variant(tmp_path, _set("inputs.payload_mass", None))
    with Plant(mapping=path) as plant:
        z = np.zeros(3)
        plant.set_input_groups((0.0,) * 4, (1.0,) * 4, z, z, z, 0.0)  # nothing asked of the missing input
        assert not plant.supports("payload_mass") and plant.supports("wind")
        with pytest.raises(PlantError, match=r"sets payload_mass but the plant mapping variant\.yaml gives the FMU no"):
            plant.set_input_groups((0.0,) * 4, (1.0,) * 4, z, z, z, 2.0)
