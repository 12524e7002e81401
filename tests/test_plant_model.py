"""The FMU against the paper's rotational model (eqs. 3-5) and RK4's order of accuracy."""

from __future__ import annotations

import numpy as np
import pytest

from plant_fmu import Plant

IXX, IYY, IZZ = 0.121, 0.121, 0.151  # the paper's §4 inertia


def euler_rate_matrix(roll: float, pitch: float) -> np.ndarray:
    """W with omega_body = W(eta) * eta_dot for ZYX angles."""
    sr, cr, sp, cp = np.sin(roll), np.cos(roll), np.sin(pitch), np.cos(pitch)
    return np.array([[1, 0, -sp], [0, cr, sr * cp], [0, -sr, cr * cp]])


def paper_J(roll: float, pitch: float, izz: float = IZZ) -> np.ndarray:
    """Eq. (4) as printed."""
    sr, cr, sp, cp = np.sin(roll), np.cos(roll), np.sin(pitch), np.cos(pitch)
    return np.array([
        [IXX, 0, -IXX * sp],
        [0, IYY * cr**2 + izz * sr**2, (IYY - izz) * sr * cr * cp],
        [-IXX * sp, (IYY - izz) * sr * cr * cp, IXX * sp**2 + IYY * sr**2 * cp**2 + izz * cr**2 * cp**2],
    ])


def paper_C(roll: float, pitch: float, rd: float, pd: float, yd: float, izz: float = IZZ) -> np.ndarray:
    """Eq. (5) with the two printed typos corrected: C12 reads psi where psi_dot is meant,
    and C31 lacks the cos(theta)^2 factor of its first term (both derived from C = W^T(I W_dot + [w]x I W))."""
    sr, cr, sp, cp = np.sin(roll), np.cos(roll), np.sin(pitch), np.cos(pitch)
    c12 = (IYY - izz) * (pd * sr * cr + yd * sr**2 * cp) - (IYY - izz) * yd * cr**2 * cp - IXX * yd * cp
    c13 = (izz - IYY) * yd * sr * cr * cp**2
    c22 = (izz - IYY) * rd * sr * cr
    c23 = -IXX * yd * cp * sp + IYY * yd * cp * sp * sr**2 + izz * yd * cp * sp * cr**2
    c31 = (IYY - izz) * yd * sr * cr * cp**2 - IXX * pd * cp
    c32 = ((izz - IYY) * (pd * sr * cr * sp + rd * sr**2 * cp) + (IYY - izz) * rd * cr**2 * cp
           + IXX * yd * cp * sp - IYY * yd * sr**2 * cp * sp - izz * yd * cr**2 * cp * sp)
    c33 = ((IYY - izz) * rd * sr * cr * cp**2 - IYY * pd * sr**2 * cp * sp - izz * pd * cr**2 * cp * sp
           + IXX * pd * cp * sp)
    return np.array([[0, c12, c13], [-c12, c22, c23], [c31, c32, c33]])


TUMBLE = {"Ixx": IXX, "Iyy": IYY, "Izz": IZZ * 1.3, "arm_length": 0.5, "init_pos_d": -5000.0,
          "integration_step": 1e-5, "motor_tau": 0.0}


def tumbling_inputs(plant: Plant, t: float) -> np.ndarray:
    u = np.zeros(len(plant.input_names))
    for i in range(1, 5):
        u[plant.input_index[f"motor_health_{i}"]] = 1.0
    u[plant.input_index["tau_dist_x"]] = 0.6 * np.sin(2.0 * t) + 0.3
    u[plant.input_index["tau_dist_y"]] = 0.4 * np.cos(1.3 * t) + 0.2
    u[plant.input_index["tau_dist_z"]] = 0.4
    u[plant.input_index["motor_cmd_1"]] = 0.3  # a rotor torque too, through the arm geometry
    return u


def test_rotational_dynamics_match_paper_lagrangian_form(fmu_path):
    izz = TUMBLE["Izz"]
    h = 1e-4
    checked = 0
    with Plant(TUMBLE, fmu_path) as plant:
        names = ["roll", "pitch", "yaw", "rate_x", "rate_y", "rate_z", "torque_x", "torque_y", "torque_z"]
        idx = [plant.output_index[n] for n in names]
        history = []
        n = 0
        while plant.t < 3.0:
            if n % 200 == 0:  # torques held for 20 ms, so a central difference never straddles a change
                u = tumbling_inputs(plant, plant.t)
                plant.set_inputs(u)
            n += 1
            out = plant.step(h)
            tau_dist = u[[plant.input_index[f"tau_dist_{a}"] for a in "xyz"]]
            history.append((out[idx].copy(), tau_dist))
        peak_rates = np.zeros(3)
        for k in range(1100, len(history) - 2, 200):  # mid-hold samples
            around = [history[k + j][0] for j in (-2, -1, 1, 2)]
            cur, tau_d = history[k]
            roll, pitch = cur[0], cur[1]
            if abs(pitch) > 1.0:  # near the ZYX singularity the finite difference of W^-1 w is ill-conditioned
                continue
            eta_dot_cur = np.linalg.solve(euler_rate_matrix(roll, pitch), cur[3:6])
            d = [np.linalg.solve(euler_rate_matrix(s[0], s[1]), s[3:6]) for s in around]
            eta_ddot = (d[0] - 8 * d[1] + 8 * d[2] - d[3]) / (12 * h)  # 5-point central difference
            tau_body = cur[6:9] + tau_d
            lhs = (paper_J(roll, pitch, izz=izz) @ eta_ddot
                   + paper_C(roll, pitch, *eta_dot_cur, izz=izz) @ eta_dot_cur)
            rhs = euler_rate_matrix(roll, pitch).T @ tau_body
            assert lhs == pytest.approx(rhs, rel=2e-4, abs=2e-5)
            peak_rates = np.maximum(peak_rates, np.abs(cur[3:6]))
            checked += 1
    assert checked >= 40
    assert peak_rates.min() > 0.5, "the trajectory must rotate fast about all three axes"
    assert max(abs(h_[0][0]) for h_ in history) > 1.0  # large angles were visited


def final_state(fmu_path, step: float) -> np.ndarray:
    params = dict(TUMBLE, integration_step=step, motor_tau=0.05)
    with Plant(params, fmu_path) as plant:
        names = ["pos_n", "pos_e", "pos_d", "q_w", "q_x", "q_y", "q_z", "rate_x", "rate_y", "rate_z"]
        idx = [plant.output_index[n] for n in names]
        dt = 0.02
        while plant.t < 2.0 - 1e-9:
            u = tumbling_inputs(plant, plant.t)
            u[plant.input_index["motor_cmd_3"]] = 0.5 + 0.5 * np.sin(3 * plant.t)
            plant.set_inputs(u)
            out = plant.step(dt)
        return out[idx].copy()


def test_rk4_error_drops_sixteen_fold_when_step_halves(fmu_path):
    reference = final_state(fmu_path, 0.02 / 128)
    coarse = np.abs(final_state(fmu_path, 0.02 / 4) - reference).max()
    fine = np.abs(final_state(fmu_path, 0.02 / 8) - reference).max()
    assert 12.0 < coarse / fine < 20.0, (coarse, fine)
