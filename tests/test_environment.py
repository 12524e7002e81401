"""What the world does at mission time t, against hand values: steady wind plus the 1 − cos gust, payload
steps, motor faults, disturbance expressions, and nothing but wind before the mission starts."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hil.scenario.environment import Environment
from hil.scenario.schema import Scenario
from hil.scenario.wind import BLOCK, KNOT, DrydenTurbulence


def environment(**fields) -> Environment:
    scenario = Scenario.model_validate({"name": "t", "duration_s": 30, "reference": {"type": "hover"}, **fields})
    return Environment(scenario, 0.004, np.random.default_rng(0), 4)


def test_a_gust_adds_half_one_minus_cosine_of_its_peak_to_the_steady_wind():
    env = environment(wind={"steady_ned": [2, 0, 0], "gusts": [{"start_s": 10, "duration_s": 4,
                                                                "peak_ned": [0, 6, 0]}]})
    assert env.sample(9.99).wind_ned == pytest.approx((2, 0, 0))
    assert env.sample(11.0).wind_ned == pytest.approx((2, 3, 0))  # a quarter in: ½(1 − cos π/2) = ½
    assert env.sample(12.0).wind_ned == pytest.approx((2, 6, 0))  # half way: the peak
    assert env.sample(14.5).wind_ned == pytest.approx((2, 0, 0))


def test_payload_steps_hold_from_their_time_on_and_the_last_one_wins():
    env = environment(payload=[{"t_s": 15, "mass_kg": 0.2}, {"t_s": 5, "mass_kg": 0.5}])
    assert [env.sample(t).payload_kg for t in (0, 5, 14.9, 15, 29)] == [0.0, 0.5, 0.5, 0.2, 0.2]


def test_a_motor_fault_scales_only_its_motor_and_only_while_it_lasts():
    env = environment(faults={"motors": [{"motor": 3, "start_s": 4, "end_s": 6, "health": 0.25}]})
    assert env.sample(3.9).motor_health == (1.0, 1.0, 1.0, 1.0)
    assert env.sample(5.0).motor_health == (1.0, 1.0, 0.25, 1.0)
    assert env.sample(6.0).motor_health == (1.0, 1.0, 1.0, 1.0)


def test_disturbance_expressions_are_evaluated_at_mission_time():
    env = environment(disturbance={"force_ned": ["sin(t)", 0, "2*t"], "torque_frd": [0, 0.1, 0]})
    sample = env.sample(0.5)
    assert sample.force_ned == pytest.approx((np.sin(0.5), 0, 1.0)) and sample.torque_frd == pytest.approx((0, 0.1, 0))


def test_before_the_mission_only_the_wind_acts():
    env = environment(wind={"steady_ned": [0, 1, 0], "gusts": [{"start_s": 0, "duration_s": 2, "peak_ned": [5, 0, 0]}]},
                      payload=[{"t_s": 0, "mass_kg": 1.0}], disturbance={"force_ned": [1, 1, 1]},
                      faults={"motors": [{"motor": 1, "start_s": 0, "health": 0.0}]})
    before = env.sample(-3.0)
    assert before.wind_ned == pytest.approx((0, 1, 0)) and before.payload_kg == 0.0
    assert not before.force_ned.any() and before.motor_health == (1.0, 1.0, 1.0, 1.0)


def test_turbulence_filtered_ahead_in_blocks_is_the_filter_stepped_one_draw_at_a_time():
    """The turbulence's generator is its own, so filtering BLOCK steps ahead must give the velocities of the
    plain rule (three N(0, 1)·√(π/dt) draws a step through the filters, rotated to NED), exactly, across blocks."""
    dt, heading = 0.004, 0.7
    ahead = DrydenTurbulence(15 * KNOT, 12.0, 3.0, heading, dt, np.random.default_rng(5))
    plain = DrydenTurbulence(15 * KNOT, 12.0, 3.0, heading, dt, np.random.default_rng(5))
    rng, (a_u, b_u, x_u), v, w = plain.rng, plain._u, list(plain._v), list(plain._w)

    def second_order(f: list[float], n: float) -> float:
        f[8], f[9] = f[0] * f[8] + f[1] * f[9] + f[4] * n, f[2] * f[8] + f[3] * f[9] + f[5] * n
        return f[6] * f[8] + f[7] * f[9]

    for _ in range(2 * BLOCK + 7):
        n_u, n_v, n_w = (rng.standard_normal(3) * math.sqrt(math.pi / dt)).tolist()
        x_u = a_u * x_u + b_u * n_u
        across, down = second_order(v, n_v), second_order(w, n_w)
        expected = (x_u * math.cos(heading) - across * math.sin(heading),
                    x_u * math.sin(heading) + across * math.cos(heading), down)
        assert ahead.sample() == expected
