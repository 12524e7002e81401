"""Rotor aerodynamics in the plant FMU against closed forms derived by hand from the model's equations:
rotor drag F = -k_d W v_inplane per rotor, induced inflow T - k_z W v_climb, translational lift
T + k_h |v_inplane|^2, flapping M = -k_flap W (v_inplane x z_body), parasitic drag -1/2 rho CdA |v| v,
with W = sqrt(T / k_eta) and k_eta = thrust_max / rotor_speed_max^2. Each test switches on one term
(linear body drag off) and starts level and at rest in the air, so the hub air velocity is -wind in FRD.
"""

from __future__ import annotations

import hashlib
import math

import numpy as np
import pytest

from plant_fmu import Plant
from tests.test_plant_physics import G, hover_u, inputs, run

NO_DRAG = {"drag_coeff_x": 0.0, "drag_coeff_y": 0.0, "drag_coeff_z": 0.0, "init_pos_d": -50.0,
           "motor_tau": 0.0, "thrust_curve_k": 0.5, "rotor_speed_max": 900.0}
T_HOVER = G / 4  # N per rotor, 1 kg
K_ETA = 5.0 / 900.0**2
W_HOVER = math.sqrt(T_HOVER / K_ETA)  # rad/s
# Measured with the FMU as it was before rotor aerodynamics existed (commit c749490), over the excitation
# below: with every new coefficient zero the plant must give the same bytes.
DIGEST_BEFORE_ROTOR_AERO = "b90b096aab09699fef411e0ded5ad33ec69e524a1c77324c748db1558e4cf2ca"


def hovering(plant: Plant, **named: float) -> np.ndarray:
    return inputs(plant, [hover_u(1.0)] * 4, **named)


def test_with_every_coefficient_zero_the_plant_is_the_one_before(fmu_path):
    with Plant({"init_pos_d": -50.0, "rotor_speed_max": 321.0, "air_density": 0.9}) as plant:
        idx = plant.input_index
        names = [n for n in plant.output_names if not n.startswith(("rotor_speed", "battery_", "cell_voltage_"))]
        u = np.zeros(len(plant.input_names))
        digest = hashlib.sha256()
        for k in range(500):  # tumbling in a varying wind
            t = k * 0.004
            for i in range(4):
                u[idx[f"motor_cmd_{i + 1}"]] = 0.6 + 0.3 * np.sin(7 * t + i)
                u[idx[f"motor_health_{i + 1}"]] = 1.0
            u[idx["wind_n"]], u[idx["wind_e"]], u[idx["wind_d"]] = 3 * np.sin(t), 4.0, -1.0
            plant.set_inputs(u)
            out = plant.step(0.004)
            digest.update(np.asarray([out[plant.output_index[n]] for n in names], dtype=np.float64).tobytes())
    assert digest.hexdigest() == DIGEST_BEFORE_ROTOR_AERO


def test_rotor_speed_follows_the_thrust_curve(fmu_path):
    with Plant(NO_DRAG) as plant:
        out = run(plant, hovering(plant), 0.1)
        for i in range(1, 5):
            assert out[plant.output_index[f"rotor_speed_{i}"]] == pytest.approx(W_HOVER, rel=1e-9)


def test_rotor_drag_pushes_with_the_wind_and_relaxes_to_it_with_the_closed_form_time_constant(fmu_path):
    k_d, wind = 1.2e-4, 5.0
    with Plant({**NO_DRAG, "rotor_drag_coeff": k_d}) as plant:
        u = hovering(plant, wind_e=wind)
        plant.set_inputs(u)
        first = plant.step(1e-6).copy()
        force_n = k_d * 4 * W_HOVER * wind  # F = -k_d sum(W) v_air with v_air = -wind: downwind
        assert first[plant.output_index["acc_e"]] == pytest.approx(force_n / 1.0, rel=1e-3)
        tau = 1.0 / (k_d * 4 * W_HOVER)  # m dv/dt = k_d sum(W) (w - v)
        out = run(plant, u, 2.0)
        assert out[plant.output_index["vel_e"]] == pytest.approx(wind * (1 - math.exp(-2.0 / tau)), rel=1e-4)
        assert abs(out[plant.output_index["vel_d"]]) < 1e-9  # the thrust itself is unchanged
        assert abs(out[plant.output_index["roll"]]) < 1e-9 and abs(out[plant.output_index["yaw"]]) < 1e-9


@pytest.mark.parametrize("wind_d", [-2.0, +1.5])  # an updraught, a downdraught
def test_induced_inflow_changes_thrust_by_k_z_w_v_climb(fmu_path, wind_d):
    k_z = 2.3e-4
    with Plant({**NO_DRAG, "induced_inflow_coeff": k_z}) as plant:
        plant.set_inputs(hovering(plant, wind_d=wind_d))
        out = plant.step(1e-6)
        climb = wind_d  # at rest, the rotor climbs through the air at the downdraught's speed
        thrust = 4 * (T_HOVER - k_z * W_HOVER * climb)
        assert out[plant.output_index["acc_d"]] == pytest.approx(G - thrust / 1.0, rel=1e-6, abs=1e-9)


def test_translational_lift_adds_k_h_times_edgewise_speed_squared(fmu_path):
    k_h, wind = 3e-3, 4.0
    with Plant({**NO_DRAG, "translational_lift_coeff": k_h}) as plant:
        plant.set_inputs(hovering(plant, wind_n=wind))
        out = plant.step(1e-6)
        assert out[plant.output_index["acc_d"]] == pytest.approx(G - 4 * (T_HOVER + k_h * wind**2), rel=1e-6)


# Wind from each direction (the air moving the other way), and the moment M = -k_flap W (v x z_body)
# it gives on a level vehicle facing north: air from ahead pitches the nose up (+pitch in FRD), air from
# the right (east) rolls it to the left (-roll): the disc tilts away from the relative wind.
@pytest.mark.parametrize("wind_n,wind_e,axis,sign", [(-5.0, 0.0, "y", +1), (5.0, 0.0, "y", -1),
                                                      (0.0, -5.0, "x", -1), (0.0, 5.0, "x", +1)])
def test_flapping_moment_has_the_equations_sign_and_axis(fmu_path, wind_n, wind_e, axis, sign):
    k_flap, dt = 2e-5, 1e-6
    with Plant({**NO_DRAG, "flapping_coeff": k_flap}) as plant:
        plant.set_inputs(hovering(plant, wind_n=wind_n, wind_e=wind_e))
        out = plant.step(dt)
        moment = sign * k_flap * 4 * W_HOVER * 5.0
        inertia = 0.011  # Ixx = Iyy, the FMU's default
        other = "x" if axis == "y" else "y"
        assert out[plant.output_index[f"rate_{axis}"]] == pytest.approx(moment / inertia * dt, rel=1e-3)
        assert abs(out[plant.output_index[f"rate_{other}"]]) < 1e-9


def test_parasitic_drag_is_quadratic_in_airspeed(fmu_path):
    area, rho = 0.02, 1.225
    for wind in (3.0, 6.0):
        with Plant({**NO_DRAG, "parasitic_drag_area_x": area, "parasitic_drag_area_y": area}) as plant:
            plant.set_inputs(hovering(plant, wind_n=wind))
            out = plant.step(1e-6)
            assert out[plant.output_index["acc_n"]] == pytest.approx(0.5 * rho * area * wind**2, rel=1e-3)


def hold_position(plant: Plant, wind_e: float, seconds: float) -> np.ndarray:
    """A plain cascaded PD (position -> tilt -> rotor thrusts) holding the origin 50 m up in a wind."""
    from plant_fmu.hover import rotor_command_for_thrust

    o, a, c = plant.output_index, 0.25 / math.sqrt(2), 0.016
    x_sign, y_sign, spin = (1, -1, 1, -1), (1, -1, -1, 1), (1, 1, -1, -1)
    u = hovering(plant, wind_e=wind_e)
    out = plant.outputs()
    for _ in range(int(seconds / 0.004)):
        roll_cmd = math.atan((-1.0 * out[o["pos_e"]] - 1.5 * out[o["vel_e"]]) / G)  # +roll tilts thrust east
        pitch_cmd = -math.atan((-1.0 * out[o["pos_n"]] - 1.5 * out[o["vel_n"]]) / G)
        tau = (0.011 * (25 * (roll_cmd - out[o["roll"]]) - 10 * out[o["rate_x"]]),
               0.011 * (25 * (pitch_cmd - out[o["pitch"]]) - 10 * out[o["rate_y"]]),
               0.021 * (-4 * out[o["yaw"]] - 4 * out[o["rate_z"]]))
        altitude, climb = -out[o["pos_d"]], -out[o["vel_d"]]
        up = 2.0 * (50.0 - altitude) - 2.5 * climb
        total = (G + up) / (math.cos(out[o["roll"]]) * math.cos(out[o["pitch"]]))
        for i in range(4):
            thrust = (total / 4 - y_sign[i] * tau[0] / (4 * a) + x_sign[i] * tau[1] / (4 * a)
                      + spin[i] * tau[2] / (4 * c))
            u[plant.input_index[f"motor_cmd_{i + 1}"]] = rotor_command_for_thrust(max(thrust, 0.0), 5.0, 0.5)
        plant.set_inputs(u)
        out = plant.step(0.004)
    return out.copy()


def test_rotor_drag_equilibrium_tilt_in_a_steady_wind_matches_the_force_balance(fmu_path):
    """Holding position in a wind w from the west, the vehicle settles rolled into it by phi with
    T sin(phi) = -k_d W w cos^2(phi) summed over rotors (in-plane air speed w cos(phi)) and
    T cos(phi) - k_d W w cos(phi) sin(phi) = m g: tan(phi) = -k_d sum(W) w cos(phi) / sum(T)."""
    k_d, wind = 1.2e-4, 5.0
    with Plant({**NO_DRAG, "rotor_drag_coeff": k_d}) as plant:
        out = hold_position(plant, wind, 30.0)
        o = plant.output_index
        assert abs(out[o["vel_e"]]) < 1e-4 and abs(out[o["vel_d"]]) < 1e-4  # settled
        roll = out[o["roll"]]
        thrust = sum(out[o[f"thrust_{i}"]] for i in range(1, 5))
        speeds = sum(out[o[f"rotor_speed_{i}"]] for i in range(1, 5))
        assert math.tan(roll) == pytest.approx(-k_d * speeds * wind * math.cos(roll) / thrust, rel=1e-3)
        assert thrust * math.cos(roll) - k_d * speeds * wind * math.cos(roll) * math.sin(roll) == pytest.approx(
            G, rel=1e-4)
        assert roll < -0.01  # into the wind, by more than half a degree
