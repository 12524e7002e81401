"""The attitude maths and the local frame both sides share, against facts derived by hand and an
independent library (pymap3d for geodesy)."""

from __future__ import annotations

import math

import numpy as np
import pymap3d
import pytest

from firmware_interface.emulator.geometry import (
    euler_rates,
    euler_to_quat,
    quat_to_dcm,
    quat_to_euler,
    wrap_pi,
)
from firmware_interface.geodesy import LocalFrame

HOME = LocalFrame(47.397742, 8.545594, 488.0)  # PX4's default SITL home


@pytest.mark.parametrize(("rpy", "q"), [
    ((0.0, 0.0, math.pi / 2), (math.cos(math.pi / 4), 0.0, 0.0, math.sin(math.pi / 4))),  # 90° about down
    ((math.pi / 2, 0.0, 0.0), (math.cos(math.pi / 4), math.sin(math.pi / 4), 0.0, 0.0)),  # 90° about north
    ((0.0, math.pi / 6, 0.0), (math.cos(math.pi / 12), 0.0, math.sin(math.pi / 12), 0.0)),  # 30° about east
])
def test_single_axis_rotations_by_hand(rpy, q):
    """A rotation by θ about one axis is the quaternion (cos θ/2, sin θ/2 · axis)."""
    assert euler_to_quat(*rpy) == pytest.approx(q, abs=1e-12)
    assert quat_to_euler(np.array(q)) == pytest.approx(rpy, abs=1e-12)


def test_a_yawed_body_x_axis_points_east_and_a_pitched_one_up():
    east = quat_to_dcm(euler_to_quat(0.0, 0.0, math.pi / 2)) @ np.array((1.0, 0.0, 0.0))
    nose_up = quat_to_dcm(euler_to_quat(0.0, math.radians(10), 0.0)) @ np.array((1.0, 0.0, 0.0))
    assert east == pytest.approx((0.0, 1.0, 0.0), abs=1e-12)
    assert nose_up == pytest.approx((math.cos(math.radians(10)), 0.0, -math.sin(math.radians(10))), abs=1e-12)


def test_euler_and_quaternion_round_trip_and_the_dcm_is_a_rotation():
    rng = np.random.default_rng(3)
    for _ in range(200):
        rpy = rng.uniform((-3.0, -1.5, -3.1), (3.0, 1.5, 3.1))
        q = euler_to_quat(*rpy)
        assert np.linalg.norm(q) == pytest.approx(1.0, abs=1e-12)
        assert quat_to_euler(q) == pytest.approx(rpy, abs=1e-9)
        r = quat_to_dcm(q)
        assert r @ r.T == pytest.approx(np.eye(3), abs=1e-12) and np.linalg.det(r) == pytest.approx(1.0)


def test_euler_rates_of_a_level_vehicle_are_its_body_rates_and_a_banked_yaw_shows_in_q_and_r():
    """Level: η̇ = ω. Rolled by φ and turning at ψ̇ with θ = 0: ω = (0, ψ̇ sin φ, ψ̇ cos φ) (by hand)."""
    assert euler_rates(np.zeros(3), np.array((0.1, -0.2, 0.3))) == pytest.approx((0.1, -0.2, 0.3))
    phi, psi_dot = math.radians(30), 0.5
    body = np.array((0.0, psi_dot * math.sin(phi), psi_dot * math.cos(phi)))
    assert euler_rates(np.array((phi, 0.0, 0.0)), body) == pytest.approx((0.0, 0.0, psi_dot), abs=1e-12)


@pytest.mark.parametrize(("angle", "wrapped"), [(3 * math.pi / 2, -math.pi / 2), (-3 * math.pi / 2, math.pi / 2),
                                                (0.25, 0.25), (2 * math.pi + 0.1, 0.1)])
def test_wrap_pi(angle, wrapped):
    assert wrap_pi(angle) == pytest.approx(wrapped, abs=1e-12)


def test_the_local_frame_is_exact_at_the_origin_and_round_trips():
    assert HOME.to_ned(HOME.lat0_deg, HOME.lon0_deg, HOME.alt0_m) == (0.0, 0.0, 0.0)
    lat, lon, alt = HOME.to_geodetic(120.0, -75.0, -30.0)
    assert HOME.to_ned(lat, lon, alt) == pytest.approx((120.0, -75.0, -30.0), abs=1e-9)
    assert alt == pytest.approx(518.0)


def test_one_arc_second_north_is_the_meridian_radius_by_hand():
    """M = a(1 − e²)/(1 − e² sin²φ)^{3/2} with WGS84's a and e² (NIMA TR8350.2), plus the height."""
    a, e2, phi = 6_378_137.0, 6.69437999014e-3, math.radians(HOME.lat0_deg)
    meridian = a * (1 - e2) / (1 - e2 * math.sin(phi) ** 2) ** 1.5
    north, _, _ = HOME.to_ned(HOME.lat0_deg + 1 / 3600, HOME.lon0_deg, HOME.alt0_m)
    # rel 1e-9: (lat + 1") - lat loses ~1e-11 of the arc second to rounding near 47°
    assert north == pytest.approx((meridian + HOME.alt0_m) * math.radians(1 / 3600), rel=1e-9)
    assert north == pytest.approx(30.88, abs=0.01)  # one arc second of latitude near 47° N


@pytest.mark.parametrize("ned", [(100.0, 0.0, 0.0), (0.0, 100.0, 0.0), (70.0, -70.0, -20.0)])
def test_the_first_order_frame_agrees_with_pymap3d_over_a_flight_area(ned):
    """~d²/2R away from the origin: a millimetre at 100 m (docs/architecture.md)."""
    lat, lon, alt = pymap3d.ned2geodetic(*ned, HOME.lat0_deg, HOME.lon0_deg, HOME.alt0_m)
    assert np.linalg.norm(np.subtract(HOME.to_ned(lat, lon, alt), ned)) < 2e-3
