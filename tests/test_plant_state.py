"""PlantState reads each quantity from its place in the FMU's output vector (checked by name against
the variable table, not against the state's own slices), and the grouped inputs land on their inputs."""

from __future__ import annotations

import numpy as np
import pytest

from plant_fmu import Plant


def test_each_field_holds_the_outputs_of_its_names(fmu_path):
    """Each field from the FMU variables the default mapping names, written out here by hand."""
    with Plant({}, fmu_path) as plant:
        outputs = np.arange(len(plant.output_names), dtype=float)
        state = plant._reader.state(outputs, True)
        index = {name: i for i, name in enumerate(plant.output_names)}
    expect = {"pos_ned": ("pos_n", "pos_e", "pos_d"), "vel_ned": ("vel_n", "vel_e", "vel_d"),
              "acc_ned": ("acc_n", "acc_e", "acc_d"), "q_wxyz": ("q_w", "q_x", "q_y", "q_z"),
              "rpy": ("roll", "pitch", "yaw"), "rates_frd": ("rate_x", "rate_y", "rate_z"),
              "specific_force_frd": ("specific_force_x", "specific_force_y", "specific_force_z"),
              "thrusts_n": tuple(f"thrust_{i}" for i in range(1, 5)),
              "rotor_speeds_rad_s": tuple(f"rotor_speed_{i}" for i in range(1, 5)),
              "torque_frd": ("torque_x", "torque_y", "torque_z")}
    for field, names in expect.items():
        assert getattr(state, field).tolist() == [float(index[n]) for n in names], field
    assert (state.thrust_total_n, state.total_mass_kg, state.on_ground) == (
        index["thrust_total"], index["total_mass"], True)


def test_grouped_inputs_reach_the_inputs_of_their_names(fmu_path):
    with Plant({}, fmu_path) as plant:
        plant.set_input_groups((0.1, 0.2, 0.3, 0.4), (1.0, 0.9, 0.8, 0.7), np.array((1.0, 2.0, 3.0)),
                               np.array((4.0, 5.0, 6.0)), np.array((0.01, 0.02, 0.03)), 0.25)
        values = plant._in_view  # what goes to fmi2SetReal, in input_names order
        named = dict(zip(plant.input_names, values.tolist(), strict=True))
        assert [named[f"motor_cmd_{i}"] for i in range(1, 5)] == [0.1, 0.2, 0.3, 0.4]
        assert [named[f"motor_health_{i}"] for i in range(1, 5)] == [1.0, 0.9, 0.8, 0.7]
        assert [named[n] for n in ("wind_n", "wind_e", "wind_d", "f_dist_n", "f_dist_e", "f_dist_d")] == [
            1.0, 2.0, 3.0, 4.0, 5.0, 6.0]
        assert [named[n] for n in ("tau_dist_x", "tau_dist_y", "tau_dist_z", "payload_mass")] == pytest.approx(
            [0.01, 0.02, 0.03, 0.25])
        state = plant.state()
        plant.step(0.004)
        assert not np.shares_memory(state.pos_ned, plant.outputs())  # a copy: the next step leaves it alone
