"""Plant physics against hand-derived facts: equilibria, free fall, signs, wind, payload."""

from __future__ import annotations

import math

import numpy as np
import pytest

from plant_fmu import Plant

G = 9.80665


def hover_u(mass: float, thrust_max: float = 5.0, k: float = 0.5) -> float:
    """Solve k u^2 + (1-k) u = m g / (4 T_max) by hand (quadratic formula)."""
    c = mass * G / (4 * thrust_max)
    return (-(1 - k) + math.sqrt((1 - k) ** 2 + 4 * k * c)) / (2 * k)


def inputs(plant: Plant, motors: list[float], **named: float) -> np.ndarray:
    u = np.zeros(len(plant.input_names))
    for i in range(4):
        u[plant.input_index[f"motor_cmd_{i + 1}"]] = motors[i]
        u[plant.input_index[f"motor_health_{i + 1}"]] = 1.0
    for name, value in named.items():
        u[plant.input_index[name]] = value
    return u


def run(plant: Plant, u: np.ndarray, seconds: float, dt: float = 0.004) -> np.ndarray:
    plant.set_inputs(u)
    out = plant.outputs()
    for _ in range(round(seconds / dt)):
        out = plant.step(dt)
    return out.copy()


def test_hover_command_holds_position_within_1mm(fmu_path):
    u0 = hover_u(1.0)
    with Plant({"init_pos_d": -10.0}, fmu_path) as plant:
        u = inputs(plant, [u0] * 4)
        plant.reset({"init_pos_d": -10.0}, initial_inputs=u)
        out = run(plant, u, 5.0)
        pos = out[[plant.output_index[f"pos_{a}"] for a in "ned"]]
        assert np.abs(pos - [0, 0, -10]).max() < 1e-3
        assert not plant.on_ground


def test_free_fall_follows_half_g_t_squared_until_ground(fmu_path):
    params = {"init_pos_d": -100.0, "drag_coeff_x": 0.0, "drag_coeff_y": 0.0, "drag_coeff_z": 0.0}
    with Plant(params, fmu_path) as plant:
        plant.set_inputs(inputs(plant, [0] * 4))
        t_ground = math.sqrt(2 * 100 / G)
        dt = 0.004
        i_d = plant.output_index["pos_d"]
        while plant.t + dt < t_ground:
            out = plant.step(dt)
            expected = -100 + 0.5 * G * plant.t**2
            assert out[i_d] == pytest.approx(expected, rel=1e-6, abs=1e-9)
            assert out[plant.output_index["specific_force_z"]] == pytest.approx(0.0, abs=1e-9)
        out = run(plant, inputs(plant, [0] * 4), 1.0)
        assert out[i_d] == 0.0
        assert plant.on_ground


def test_resting_on_ground_with_zero_thrust_stays_put_for_10s(fmu_path):
    with Plant(None, fmu_path) as plant:
        plant.set_inputs(inputs(plant, [0] * 4))
        i_pos = [plant.output_index[f"pos_{a}"] for a in "ned"]
        i_vel = [plant.output_index[f"vel_{a}"] for a in "ned"]
        for _ in range(2500):
            out = plant.step(0.004)
            assert np.all(out[i_pos] == 0.0) and np.all(out[i_vel] == 0.0)
        assert np.all(np.isfinite(out))
        assert out[plant.output_index["specific_force_z"]] == pytest.approx(-G)
        assert plant.on_ground


def test_lifts_off_when_thrust_exceeds_weight(fmu_path):
    with Plant({"motor_tau": 0.0, "drag_coeff_z": 0.0}, fmu_path) as plant:
        thrust_each = 1.2 * G / 4  # 20 % over weight: a = 0.2 g upward
        u = thrust_each / 5.0
        u_cmd = (-(0.5) + math.sqrt(0.25 + 2 * u)) / 1.0
        out = run(plant, inputs(plant, [u_cmd] * 4), 1.0)
        assert out[plant.output_index["pos_d"]] == pytest.approx(-0.5 * 0.2 * G * 1.0**2, rel=1e-3)
        assert not plant.on_ground


def test_payload_step_gives_analytic_downward_acceleration(fmu_path):
    mass, payload = 1.0, 0.5
    with Plant({"init_pos_d": -20.0, "drag_coeff_z": 0.0}, fmu_path) as plant:
        u = inputs(plant, [hover_u(mass)] * 4)
        plant.reset({"init_pos_d": -20.0, "drag_coeff_z": 0.0}, initial_inputs=u)
        run(plant, u, 0.1)
        u[plant.input_index["payload_mass"]] = payload
        out = run(plant, u, 0.004)
        expected = G * payload / (mass + payload)
        assert out[plant.output_index["acc_d"]] == pytest.approx(expected, rel=1e-9)
        assert out[plant.output_index["total_mass"]] == mass + payload
        z0 = out[plant.output_index["pos_d"]]
        v0 = out[plant.output_index["vel_d"]]
        out = run(plant, u, 0.5)
        assert out[plant.output_index["pos_d"]] == pytest.approx(z0 + v0 * 0.5 + 0.5 * expected * 0.25, rel=1e-6)


@pytest.mark.parametrize(
    ("extra_on", "rate", "sign"),
    [
        ((0, 3), "rate_x", -1),  # right rotors (1 front-right, 4 rear-right) -> roll left
        ((0, 2), "rate_y", +1),  # front rotors (1 front-right, 3 front-left) -> pitch up
        ((0, 1), "rate_z", +1),  # CCW rotors (1, 2) -> yaw right
    ],
)
def test_rotor_asymmetry_signs(fmu_path, extra_on, rate, sign):
    with Plant({"init_pos_d": -50.0}, fmu_path) as plant:
        motors = [hover_u(1.0)] * 4
        plant.reset({"init_pos_d": -50.0}, initial_inputs=inputs(plant, motors))
        for i in extra_on:
            motors[i] += 0.02
        out = run(plant, inputs(plant, motors), 0.2)
        others = {"rate_x", "rate_y", "rate_z"} - {rate}
        assert sign * out[plant.output_index[rate]] > 0.01
        for other in others:
            assert abs(out[plant.output_index[other]]) < 1e-6


def test_velocity_tends_to_steady_wind(fmu_path):
    wind = (3.0, -1.5, 0.0)
    with Plant({"init_pos_d": -50.0}, fmu_path) as plant:
        u = inputs(plant, [hover_u(1.0)] * 4, wind_n=wind[0], wind_e=wind[1])
        plant.reset({"init_pos_d": -50.0}, initial_inputs=u)
        out = run(plant, u, 60.0, dt=0.01)  # drag time constant m / c = 4 s
        vel = out[[plant.output_index[f"vel_{a}"] for a in "ne"]]
        assert vel == pytest.approx(wind[:2], abs=1e-3)


def test_a_vehicle_that_touches_down_tilted_settles_level_at_rates_its_gyro_reads(fmu_path):
    """Dropped from 0.5 m while a roll torque tilts it, the vehicle stops where it touches down and rocks onto its
    legs: on the ground roll decays as exp(-t/0.1 s) (the settling time constant), the body rate the plant reports
    is that decay's rate, -roll/0.1 s (what a gyro reads, so an estimator follows the attitude), heading and
    position stay."""
    params = {"init_pos_d": -0.5, "drag_coeff_x": 0.0, "drag_coeff_y": 0.0, "drag_coeff_z": 0.0, "Ixx": 0.02}
    dt = 0.001
    with Plant(params, fmu_path) as plant:
        plant.set_inputs(inputs(plant, [0] * 4, tau_dist_x=0.08))  # 4 rad/s²: ~0.2 rad at touch-down
        index = plant.output_index
        out = plant.outputs()
        while not plant.on_ground:
            out = plant.step(dt)
        plant.set_inputs(inputs(plant, [0] * 4))
        roll_0, yaw_0, pos_0 = out[index["roll"]], out[index["yaw"]], out[[index[f"pos_{a}"] for a in "ned"]]
        assert 0.1 < roll_0 < 0.3
        for _ in range(100):  # 0.1 s on the ground
            out = plant.step(dt)
            assert out[index["rate_x"]] == pytest.approx(-out[index["roll"]] / 0.1, rel=1e-9)
        assert out[index["roll"]] == pytest.approx(roll_0 * math.exp(-1.0), rel=2e-3)  # RK4 at 1 ms
        assert out[index["yaw"]] == pytest.approx(yaw_0, abs=1e-12)
        assert np.array_equal(out[[index[f"pos_{a}"] for a in "ned"]], pos_0) and plant.on_ground
