"""The battery in our plant FMU against closed forms: Chen and Rincon-Mora's published open-circuit voltage
curve, a constant current's linear charge loss, the I·R drop of a current step, and the energy of a hover
equal to the rotors' shaft power over the efficiency."""

from __future__ import annotations

import math

import numpy as np
import pytest

from plant_fmu import Plant, PlantError
from plant_fmu.variables import PARAMETER_DEFAULTS as DEFAULTS

Z = np.zeros(3)
CELLS, R_CELL, EFFICIENCY = 4, 0.012, 0.7


def ocv(soc: float) -> float:
    """One LiPo cell's open-circuit voltage (Chen and Rincon-Mora, IEEE Trans. Energy Conv. 21(2), 2006)."""
    return -1.031 * math.exp(-35 * soc) + 3.685 + 0.2156 * soc - 0.1178 * soc**2 + 0.3201 * soc**3


def hold(plant: Plant, commands: tuple[float, ...], seconds: float) -> None:
    for _ in range(round(seconds / 0.004)):
        plant.set_input_groups(commands, (1.0,) * 4, Z, Z, Z, 0.0)
        plant.step(0.004)


def test_a_constant_current_drains_the_charge_linearly_along_the_published_curve():
    capacity_ah, current_a = 2.0, 20.0  # 10C: the pack empties in 360 s
    with Plant({"battery_capacity": capacity_ah, "battery_base_current": current_a}) as plant:
        for t in (30.0, 120.0, 300.0):
            hold(plant, (0.0,) * 4, t - plant.t)
            battery = plant.state().battery
            assert battery is not None
            soc = 1 - current_a * t / 3600 / capacity_ah
            assert battery.current_a == pytest.approx(current_a, rel=1e-12)
            assert battery.consumed_c == pytest.approx(current_a * t, rel=1e-9)
            assert battery.remaining == pytest.approx(soc, abs=1e-9)
            assert battery.voltage_v == pytest.approx(CELLS * (ocv(soc) - current_a * R_CELL), abs=1e-9)


def test_a_current_step_drops_the_voltage_by_i_times_r_and_it_recovers():
    with Plant({"motor_tau": 0.0}) as plant:  # ideal motors: the current steps with the command
        hold(plant, (0.0,) * 4, 0.1)
        before = plant.state().battery
        hold(plant, (0.5,) * 4, 0.004)
        after = plant.state()
        battery = after.battery
        assert before is not None and battery is not None and battery.current_a > 5.0
        soc_before, soc_after = before.remaining, battery.remaining
        drop = before.voltage_v - battery.voltage_v
        assert drop == pytest.approx(battery.current_a * CELLS * R_CELL + CELLS * (ocv(soc_before) - ocv(soc_after)),
                                     abs=1e-9)
        shaft_w = sum(DEFAULTS["yaw_moment_coeff"] * t * w
                      for t, w in zip(after.thrusts_n, after.rotor_speeds_rad_s, strict=True))
        assert battery.voltage_v * battery.current_a == pytest.approx(shaft_w / EFFICIENCY, rel=1e-12)
        hold(plant, (0.0,) * 4, 0.004)
        rested = plant.state().battery
        assert rested is not None and rested.voltage_v == pytest.approx(CELLS * ocv(rested.remaining), abs=1e-12)


def test_the_energy_of_a_hover_is_the_rotors_shaft_power_over_the_efficiency():
    """Hovering, each rotor gives mg/4 at w = w_max sqrt(T/T_max) against a drag torque k_m T: the pack
    delivers 4 k_m T w / efficiency, and the charge it counts is the current integrated."""
    mass, g, t_max, k = DEFAULTS["mass"], DEFAULTS["g"], DEFAULTS["thrust_max"], DEFAULTS["thrust_curve_k"]
    thrust = mass * g / 4
    u = (-(1 - k) + math.sqrt((1 - k) ** 2 + 4 * k * thrust / t_max)) / (2 * k)
    hover_w = 4 * DEFAULTS["yaw_moment_coeff"] * thrust * DEFAULTS["rotor_speed_max"] * math.sqrt(thrust / t_max)
    electrical, shaft, charge, dt = [], [], [], 0.004
    with Plant({"init_pos_d": -10.0}) as plant:
        for _ in range(5000):  # 20 s
            plant.set_input_groups((u,) * 4, (1.0,) * 4, Z, Z, Z, 0.0)
            plant.step(dt)
            state = plant.state()
            assert state.battery is not None
            electrical.append(state.battery.voltage_v * state.battery.current_a)
            shaft.append(sum(DEFAULTS["yaw_moment_coeff"] * t * w
                             for t, w in zip(state.thrusts_n, state.rotor_speeds_rad_s, strict=True)))
            charge.append(state.battery.current_a)
        consumed = state.battery.consumed_c
    assert electrical[-1] == pytest.approx(hover_w / EFFICIENCY, rel=1e-9)  # settled rotors: the closed form
    assert np.trapezoid(electrical, dx=dt) == pytest.approx(np.trapezoid(shaft, dx=dt) / EFFICIENCY, rel=1e-12)
    # the FMU's RK4 charge against the trapezoid of the sampled current (from the first sample on)
    assert consumed - charge[0] * dt == pytest.approx(np.trapezoid(charge, dx=dt), rel=1e-5)


def test_a_failing_cell_loses_its_voltage_and_adds_its_resistance():
    with Plant({"motor_tau": 0.0}) as plant:
        hold(plant, (0.5,) * 4, 0.1)
        plant.set_battery_fault(2, 0.05, 0.4)
        hold(plant, (0.5,) * 4, 0.004)
        battery = plant.state().battery
        assert battery is not None
        cells = battery.cell_voltages_v
        healthy = ocv(battery.remaining) - battery.current_a * R_CELL
        assert cells[[0, 2, 3]] == pytest.approx([healthy] * 3, abs=1e-12)
        assert cells[1] == pytest.approx(healthy - 0.4 - battery.current_a * 0.05, abs=1e-12)
        assert np.all(cells[CELLS:] == 0.0)
        assert battery.voltage_v == pytest.approx(float(np.sum(cells)), abs=1e-12)


@pytest.mark.parametrize("bad", [{"battery_capacity": -1.0}, {"battery_cells": 15}, {"battery_efficiency": 1.5}])
def test_a_battery_that_cannot_be_is_refused_with_its_reason(bad):
    with pytest.raises(PlantError, match=r"battery: cells 1\.\.14, capacity > 0"):
        Plant(bad)
