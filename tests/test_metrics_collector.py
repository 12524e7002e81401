"""MetricsCollector on frames built by hand: the tracking error only once settled and only in the mission,
attitude errors wrapped, the mass-estimate window per payload step, and the counts it reports."""

from __future__ import annotations

import math

import numpy as np
import pytest

from firmware_interface.emulator.geometry import euler_to_quat
from firmware_interface.hil_codec import SensorReadings
from hil.judge.metrics import MetricsCollector
from hil.loop.frame import StepFrame
from hil.scenario.environment import EnvironmentSample
from hil.scenario.reference import RefSample
from plant_fmu.state import PlantState

REF = RefSample(np.array((0.0, 0.0, -5.0)), np.zeros(3), np.zeros(3), 0.0)


def frame(t: float, pos=(0.0, 0.0, -5.0), rpy=(0.0, 0.0, 0.0), phase="mission", mass=1.0,
          board=()) -> StepFrame:
    zero3, zero4 = np.zeros(3), np.zeros(4)
    state = PlantState(np.array(pos, dtype=float), zero3, zero3, np.array((1.0, 0.0, 0.0, 0.0)),
                       np.array(rpy, dtype=float), zero3, zero3, zero4, zero4, zero3, 0.0, mass, False)
    env = EnvironmentSample(np.zeros(3), np.zeros(3), np.zeros(3), 0.0, (1.0, 1.0, 1.0, 1.0))
    return StepFrame(round(t * 1e6), t, phase, state, REF,
                     SensorReadings(round(t * 1e6)), None, (0.5,) * 4, True, env, list(board), step_wall_s=1e-4,
                     round_trip_s=5e-5)


def test_the_tracking_error_counts_only_settled_mission_steps():
    m = MetricsCollector(settle_s=2.0)
    m.add(frame(-1.0, pos=(9.0, 9.0, 9.0), phase="takeoff"))  # not the mission
    m.add(frame(1.0, pos=(5.0, 0.0, -5.0)))  # not settled
    m.add(frame(2.0, pos=(0.3, 0.0, -5.0)))
    m.add(frame(3.0, pos=(-0.1, 0.4, -4.8)))
    x, y, z = (m.compute()["position_error_m"][a] for a in "xyz")
    assert (x["min"], x["max"], x["max_abs"]) == pytest.approx((-0.1, 0.3, 0.3))
    assert x["rms"] == pytest.approx(math.sqrt((0.09 + 0.01) / 2))
    assert y["max"] == pytest.approx(0.4) and z["max"] == pytest.approx(0.2)
    assert m.mission_steps == 3


def test_attitude_error_against_the_commanded_quaternion_is_wrapped_to_a_half_turn():
    """Truth yaw 179°, commanded −179°: the error is −2°, not 358°."""
    m = MetricsCollector(settle_s=0.0)
    q = euler_to_quat(0.0, math.radians(1.0), math.radians(-179.0)).tolist()
    m.add(frame(1.0, rpy=(0.0, math.radians(3.0), math.radians(179.0)),
                board=[("ATTITUDE_TARGET", {"q": q, "rpy": [], "thrust": 0.5})]))
    att = m.compute()["attitude_error_deg"]
    assert att["pitch"]["max"] == pytest.approx(2.0) and att["yaw"]["max"] == pytest.approx(-2.0)


def test_mass_estimate_windows_close_at_each_payload_step():
    m = MetricsCollector(settle_s=0.0)
    for t, mass, m_hat in ((1.0, 1.0, 1.05), (9.9, 1.0, 1.1), (10.0, 1.5, 1.2), (19.9, 1.5, 1.35)):
        m.add(frame(t, mass=mass, board=[("DEBUG_FLOAT_ARRAY", {"name": "smarc", "values": {"m_hat": m_hat}})]))
    windows = m.compute()["board_estimates"]["mass_estimate_windows"]
    assert [(w["end_s"], w["true_mass_kg"]) for w in windows] == [(9.9, 1.0), (19.9, 1.5)]
    assert [w["error_pct"] for w in windows] == pytest.approx([10.0, -10.0])
