"""Each reference type from its `reference:` fields to its trajectory, against values derived by hand: the
hover's point, the helix's x = r cos(ωτ), the waypoints' rest-to-rest segments at their peak speed, the
patrol's standoff beside the line, and the yaw of each in (−π, π]."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hil.scenario.reference import HelixRef, HoverRef, PatrolRef, WaypointsRef
from hil.scenario.reference.base import wrap_yaw

PEAK = 1.875  # max ds/dx of the quintic smoothstep 10x³ − 15x⁴ + 6x⁵, at x = 1/2


def test_wrap_yaw_keeps_an_angle_in_range_bit_for_bit_and_brings_others_into_it():
    inside = np.random.default_rng(1).uniform(-math.pi, math.pi, 100_000)
    assert all(wrap_yaw(float(a)) == a for a in inside) and wrap_yaw(math.pi) == math.pi
    assert wrap_yaw(-math.pi) == math.pi  # the half-open range (−π, π]: south is +π
    outside = ((3 * math.pi / 2, -math.pi / 2), (-7.0, 2 * math.pi - 7.0), (1e6, 1e6 - 159155 * 2 * math.pi))
    for angle, expected in outside:
        assert wrap_yaw(angle) == pytest.approx(expected, abs=1e-9)


def test_hover_holds_its_point_north_east_and_up():
    hover = HoverRef(type="hover", altitude_m=4.0, north_m=3.0, east_m=-4.0, yaw_deg=-135.0).trajectory()
    for t in (0.0, 7.0, 1e5):
        r = hover.sample(t)
        assert r.pos_ned.tolist() == [3.0, -4.0, -4.0] and not r.vel_ned.any() and not r.acc_ned.any()
        assert r.yaw == pytest.approx(-3 * math.pi / 4, abs=1e-15)


@pytest.mark.parametrize(("yaw_deg", "yaw"), [(180.0, math.pi), (-180.0, math.pi), (190.0, math.radians(-170)),
                                               (-540.0, math.pi), (720.0 + 30.0, math.pi / 6)])
def test_a_yaw_in_degrees_is_flown_in_radians_in_minus_pi_to_pi(yaw_deg, yaw):
    flown = HoverRef(type="hover", yaw_deg=yaw_deg).trajectory().sample(0.0).yaw
    assert -math.pi < flown <= math.pi and flown == pytest.approx(yaw, abs=1e-13)


def test_helix_is_a_circle_about_home_on_the_warped_clock():
    """r = 3 m, ω = −0.8 rad/s, descending at 0.2 m/s from 25 m, entered over 4 s: after the start τ = t − 2;
    at t = 2, half-way through the start, s = 1/2: τ = 4·(2.5/16 − 3/32 + 1/64) = 0.3125 s and τ̇ = 1/2."""
    r, w, climb = 3.0, -0.8, -0.2
    helix = HelixRef(type="helix", radius_m=r, angular_rate=w, climb_rate=climb, yaw_deg=180.0, altitude_m=25.0,
                     ramp_s=4.0).trajectory()
    for t in (4.0, 9.5, 30.0):
        tau = t - 2.0
        sample = helix.sample(t)
        assert sample.pos_ned == pytest.approx((r * math.cos(w * tau), r * math.sin(w * tau), -25.0 - climb * tau))
        assert sample.vel_ned == pytest.approx((-r * w * math.sin(w * tau), r * w * math.cos(w * tau), -climb))
        assert sample.acc_ned == pytest.approx((-r * w * w * math.cos(w * tau), -r * w * w * math.sin(w * tau), 0.0))
        assert sample.yaw == math.pi
    halfway = helix.sample(2.0)
    tau = 0.3125
    assert halfway.pos_ned == pytest.approx((r * math.cos(w * tau), r * math.sin(w * tau), -25.0 - climb * tau))
    assert halfway.vel_ned == pytest.approx((-0.5 * r * w * math.sin(w * tau), 0.5 * r * w * math.cos(w * tau),
                                             -0.5 * climb))
    start = helix.sample(0.0)
    assert start.pos_ned == pytest.approx((r, 0.0, -25.0)) and not start.vel_ned.any() and not start.acc_ned.any()


def test_waypoints_fly_each_segment_rest_to_rest_at_the_peak_speed_facing_along_it():
    """Segments of 20, √241 and √641 m at a 4 m/s peak last 1.875·L/4 each, with a 1 s dwell at each point."""
    points = [(0.0, 0.0, -10.0), (20.0, 0.0, -10.0), (20.0, -15.0, -14.0), (0.0, 0.0, -10.0)]
    route = WaypointsRef(type="waypoints", points_ned=points, speed=4.0, dwell_s=1.0).trajectory()
    lengths = (20.0, math.sqrt(241.0), math.sqrt(641.0))
    yaws = (0.0, -math.pi / 2, math.pi - math.atan(15 / 20))
    start = 0.0
    for a, b, length, yaw in zip(points, points[1:], lengths, yaws, strict=False):
        duration = PEAK * length / 4.0
        middle = route.sample(start + duration / 2)
        assert middle.pos_ned == pytest.approx(np.add(a, b) / 2)
        assert middle.vel_ned == pytest.approx(4.0 * np.subtract(b, a) / length)  # the peak, along the segment
        assert middle.acc_ned == pytest.approx((0.0, 0.0, 0.0), abs=1e-12) and middle.yaw == pytest.approx(yaw)
        dwelling = route.sample(start + duration + 0.5)
        assert dwelling.pos_ned == pytest.approx(b) and np.abs(dwelling.vel_ned).max() == pytest.approx(0.0)
        start += duration + 1.0
    assert route.duration_s == pytest.approx(start - 1.0)
    fixed = WaypointsRef(type="waypoints", points_ned=points[:2], yaw_deg=270.0).trajectory()
    assert fixed.sample(1.0).yaw == pytest.approx(-math.pi / 2)


def test_patrol_flies_beside_the_line_at_its_standoff_and_altitude_facing_it():
    """A north-east line of 28.3·√2 m: 5 m to its right is (−5/√2, +5/√2) north-east; facing the line is −45°."""
    patrol = PatrolRef(type="patrol", line_start_ned=(0.0, 0.0, 0.0), line_end_ned=(28.3, 28.3, 0.0), standoff_m=5.0,
                       altitude_m=12.0, speed=3.0, dwell_s=2.0, passes=2).trajectory()
    right = 5.0 / math.sqrt(2)
    near, far = (-right, right, -12.0), (28.3 - right, 28.3 + right, -12.0)
    duration = PEAK * 28.3 * math.sqrt(2) / 3.0
    assert patrol.sample(0.0).pos_ned == pytest.approx(near)
    assert patrol.sample(duration / 2).pos_ned == pytest.approx(np.add(near, far) / 2)
    assert np.linalg.norm(patrol.sample(duration / 2).vel_ned) == pytest.approx(3.0)
    assert patrol.sample(duration + 1.0).pos_ned == pytest.approx(far)  # dwelling at the far end
    assert patrol.sample(2 * duration + 2.0).pos_ned == pytest.approx(near)  # back: two passes
    assert all(patrol.sample(t).yaw == pytest.approx(-math.pi / 4) for t in (0.0, duration, 2 * duration + 2.0))


def test_a_westbound_patrol_faces_south_as_plus_pi():
    """West-bound, the right-hand side is north: the vehicle flies 5 m north of the line and faces south, ±π,
    flown as +π."""
    patrol = PatrolRef(type="patrol", line_start_ned=(10.0, 0.0, 0.0), line_end_ned=(10.0, -30.0, 0.0),
                       standoff_m=5.0).trajectory()
    first = patrol.sample(0.0)
    assert first.pos_ned == pytest.approx((15.0, 0.0, -10.0)) and first.yaw == math.pi
