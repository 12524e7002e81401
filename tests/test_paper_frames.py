"""The paper's frame against the bench's, derived by hand: which signs its inputs and angles take in NED/FRD."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from firmware_interface.emulator.geometry import euler_to_quat, quat_to_dcm
from hil.scenario.environment import Environment
from hil.scenario.loader import load_scenario

ROOT = Path(__file__).resolve().parent.parent
# The paper's inertial frame B is z up (gravity −m·g·e3, eq. 2; the helix climbs z = t). Its x = cos(t/2),
# y = sin(t/2) are flown as north and east, so its (x, y, z) is NED's (north, east, −down): NED reflected in z.
M = np.diag((1.0, 1.0, -1.0))


def paper_rotation(gamma: float, theta: float, psi: float) -> np.ndarray:
    """R_AB of eq. 1, typed from the paper."""
    cg, sg, ct, st, cp, sp = (math.cos(gamma), math.sin(gamma), math.cos(theta), math.sin(theta), math.cos(psi),
                              math.sin(psi))
    return np.array(((ct * cp, st * sg * cp - sp * cg, cp * cg * st + sg * sp),
                     (ct * sp, st * sg * sp + cp * cg, st * sp * cg - sg * cp),
                     (-st, ct * sg, ct * cg)))


def bench_rotation(roll: float, pitch: float, yaw: float) -> np.ndarray:
    return quat_to_dcm(euler_to_quat(roll, pitch, yaw))


def skew_vector(s: np.ndarray) -> np.ndarray:
    return np.array((s[2, 1], s[0, 2], s[1, 0]))


ANGLES = [(0.3, -0.2, 0.5), (-0.6, 0.4, 2.0), (0.05, 0.1, -1.2)]


@pytest.mark.parametrize("gamma, theta, psi", ANGLES)
def test_the_papers_angles_are_minus_roll_minus_pitch_and_yaw(gamma, theta, psi):
    """Body axes map as vectors do (b_FRD = M·b_paper): R_NED = M·R_AB·M, which is the bench's ZYX rotation at
    (−γ, −θ, ψ)."""
    assert M @ paper_rotation(gamma, theta, psi) @ M == pytest.approx(bench_rotation(-gamma, -theta, psi), abs=1e-12)


@pytest.mark.parametrize("gamma, theta, psi", ANGLES)
def test_a_torque_maps_as_an_axial_vector_minus_x_minus_y_plus_z(gamma, theta, psi):
    """Ṙ = R·[ω]× in either frame. A motion of the paper's angles gives its body rate ω_p and the bench's ω_FRD;
    ω_FRD = (−ω_x, −ω_y, +ω_z), so the power τ·ω is the same only if τ_FRD = (−τ_x, −τ_y, +τ_z)."""
    rates, h = np.array((0.7, -0.4, 0.9)), 1e-6
    eta = np.array((gamma, theta, psi))
    r_p = paper_rotation(*eta)
    r_p_dot = (paper_rotation(*(eta + h * rates)) - paper_rotation(*(eta - h * rates))) / (2 * h)
    omega_paper = skew_vector(r_p.T @ r_p_dot)
    r_b = M @ r_p @ M
    omega_frd = skew_vector(r_b.T @ (M @ r_p_dot @ M))
    assert omega_frd == pytest.approx(omega_paper * np.array((-1.0, -1.0, 1.0)), abs=1e-8)
    tau_paper = np.array((0.8, 0.6, 1.1))
    tau_frd = tau_paper * np.array((-1.0, -1.0, 1.0))
    assert tau_frd @ omega_frd == pytest.approx(tau_paper @ omega_paper, abs=1e-8)


@pytest.mark.parametrize("name", ["paper_helix.yaml", "paper_helix_1kg.yaml"])
def test_the_scenarios_apply_the_papers_d_s_and_d_m_in_ned_and_frd(name):
    """§4: d_s = [sin πt, cos πt, cos πt], d_M = [sin(πt/2) + 0.5, cos(πt/2) + 0.5, sin(πt/2) + 0.6] in the
    paper's axes; in the bench d_s as M·d_s (NED) and d_M as (−x, −y, +z) (body FRD)."""
    scenario = load_scenario(ROOT / "scenarios" / name)
    environment = Environment(scenario, 0.001, np.random.default_rng(0), 4)
    for t in (0.0, 0.37, 1.5, 4.2, 13.9):
        sample = environment.sample(t)
        d_s = np.array((math.sin(math.pi * t), math.cos(math.pi * t), math.cos(math.pi * t)))
        d_m = np.array((math.sin(0.5 * math.pi * t) + 0.5, math.cos(0.5 * math.pi * t) + 0.5,
                        math.sin(0.5 * math.pi * t) + 0.6))
        assert sample.force_ned == pytest.approx(M @ d_s, abs=1e-12)
        assert sample.torque_frd == pytest.approx(d_m * np.array((-1.0, -1.0, 1.0)), abs=1e-12)


@pytest.mark.parametrize("gamma, theta, psi", ANGLES)
def test_the_reports_paper_frame_is_the_derived_one(gamma, theta, psi):
    """`hil report --paper-frame` draws positions as M·p and the bench's angles as the paper's."""
    from hil.reports.png import PAPER_FRAME

    p = np.array((1.0, -2.0, -3.0))
    assert PAPER_FRAME.position(p) == pytest.approx(M @ p)
    roll, pitch, yaw = PAPER_FRAME.attitude(np.array((gamma, theta, psi)))  # the map is its own inverse
    assert M @ paper_rotation(gamma, theta, psi) @ M == pytest.approx(bench_rotation(roll, pitch, yaw), abs=1e-12)
