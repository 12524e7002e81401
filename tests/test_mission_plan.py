"""The flight plan around a reference: take-off from the ground to the reference's start, the hold, the
mission clock, and the landing, against figures derived by hand from the quintic rest-to-rest profile."""

from __future__ import annotations

import numpy as np
import pytest

from hil.scenario.mission import CLIMB_SPEED, HOLD_BEFORE_S, MissionPlan
from hil.scenario.schema import Scenario

PEAK = 1.875  # max ds/dx of the quintic smoothstep 10x³ − 15x⁴ + 6x⁵, at x = 1/2


def hover(altitude_m: float = 5.0, **extra) -> Scenario:
    return Scenario.model_validate({"name": "t", "duration_s": 20, "reference": {
        "type": "hover", "altitude_m": altitude_m, **extra}})


def test_take_off_is_a_vertical_climb_then_the_hold_then_t_zero():
    plan = MissionPlan.build(hover(6.0))
    climb_s = PEAK * 6.0 / CLIMB_SPEED  # 6 m at a 1.5 m/s peak: 7.5 s
    assert plan.takeoff_s == pytest.approx(climb_s + HOLD_BEFORE_S)
    start = plan.sample(-plan.takeoff_s)
    assert start.pos_ned == pytest.approx((0, 0, 0)) and np.abs(start.vel_ned).max() == pytest.approx(0)
    midway = plan.sample(-plan.takeoff_s + climb_s / 2)
    assert midway.pos_ned == pytest.approx((0, 0, -3.0)) and midway.vel_ned[2] == pytest.approx(-CLIMB_SPEED)
    assert plan.sample(-HOLD_BEFORE_S / 2).pos_ned == pytest.approx((0, 0, -6.0))  # holding at the start
    assert plan.sample(0.0).pos_ned == pytest.approx((0, 0, -6.0))


def test_a_start_away_from_the_ground_point_climbs_first_then_moves_across():
    plan = MissionPlan.build(hover(4.0, north_m=3.0, east_m=-4.0))  # 5 m across after a 4 m climb
    climb_s, across_s = PEAK * 4.0 / CLIMB_SPEED, PEAK * 5.0 / CLIMB_SPEED
    assert plan.takeoff_s == pytest.approx(climb_s + across_s + HOLD_BEFORE_S)
    assert plan.sample(-plan.takeoff_s + climb_s).pos_ned == pytest.approx((0, 0, -4.0))
    assert plan.sample(-HOLD_BEFORE_S).pos_ned == pytest.approx((3.0, -4.0, -4.0))


def test_landing_descends_straight_down_from_where_the_vehicle_is():
    landing = MissionPlan.build(hover()).landing(np.array((2.0, 1.0, -3.0)), yaw=0.5)
    assert landing.duration_s == pytest.approx(PEAK * 3.0 / CLIMB_SPEED)
    assert landing.sample(landing.duration_s).pos_ned == pytest.approx((2.0, 1.0, 0.0))
    assert landing.sample(0.0).yaw == 0.5
