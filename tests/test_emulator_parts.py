"""Emulator parts against hand-worked facts: mixer allocation, differentiator, estimator alignment and history."""

from __future__ import annotations

import math

import numpy as np
import pytest

from firmware_interface.emulator.config import EstimatorSettings, NominalVehicle, Rotor
from firmware_interface.emulator.control.differentiator import ThirdOrderDifferentiator
from firmware_interface.emulator.estimator import HISTORY_START, Estimator
from firmware_interface.emulator.mixer import Mixer
from firmware_interface.emulator.telemetry import collective_fraction, vehicle_type
from firmware_interface.hil_codec import GpsFix, SensorReadings

VEHICLE = NominalVehicle()  # 1 kg, arm 0.25 m, 5 N rotors, k = 0.5, k_m = 0.016


def test_hover_thrust_gives_equal_commands_on_the_thrust_curve():
    u = Mixer(VEHICLE).commands(9.80665, np.zeros(3))
    # by hand: 2.4517 N per rotor = 5 (0.5 u + 0.5 u^2)  ->  u = 0.6094
    assert u == pytest.approx([0.6094] * 4, abs=1e-4)


@pytest.mark.parametrize(("torque", "more"), [((0.1, 0, 0), (1, 2)), ((0, 0.1, 0), (0, 2)), ((0, 0, 0.01), (0, 1))])
def test_torques_go_to_the_right_rotors(torque, more):
    """+roll: left rotors (2 RL, 3 FL) push more; +pitch: front (1, 3); +yaw: CCW rotors (1, 2)."""
    thrusts = Mixer(VEHICLE).rotor_thrusts(9.80665, np.array(torque))
    high = set(np.flatnonzero(thrusts > 9.80665 / 4 + 1e-9))
    assert high == set(more)
    assert thrusts.sum() == pytest.approx(9.80665)


def test_saturation_drops_yaw_first_and_never_raises_collective():
    mixer = Mixer(VEHICLE)
    low = mixer.rotor_thrusts(2.0, np.array((0.5, 0.0, 0.05)))  # big roll demand at low thrust
    assert low.min() >= 0.0 and low.sum() <= 2.0 + 1e-9
    high = mixer.rotor_thrusts(19.5, np.array((0.2, 0.0, 0.1)))  # near full thrust
    arm = 0.25 / math.sqrt(2)
    roll = -arm * (high[0] - high[1] - high[2] + high[3])
    assert roll == pytest.approx(0.2, rel=1e-6)  # roll kept whole; collective and yaw gave way
    assert high.max() <= 5.0 + 1e-9


# PX4's hexa X (airframe 6001's CA_ROTOR0..5), by hand: azimuth from the nose towards the right, and spin
HEXA = ((90, "cw"), (-90, "ccw"), (-30, "cw"), (150, "ccw"), (30, "ccw"), (-150, "cw"))
HEXA_VEHICLE = NominalVehicle(rotors=tuple(
    Rotor(position_frd_m=(0.25 * math.cos(math.radians(az)), 0.25 * math.sin(math.radians(az)), 0.0), spin=spin)
    for az, spin in HEXA))


def test_a_hexa_hovers_on_six_equal_commands():
    u = Mixer(HEXA_VEHICLE).commands(9.80665, np.zeros(3))
    # by hand: 1.6344 N per rotor = 5 (0.5 u + 0.5 u^2)  ->  u^2 + u - 0.65378 = 0  ->  u = 0.4507
    assert u == pytest.approx([0.4507] * 6, abs=1e-4)


@pytest.mark.parametrize(("torque", "more"),
                         [((0.1, 0, 0), {1, 2, 5}), ((0, 0.1, 0), {2, 4}), ((0, 0, 0.01), {1, 3, 4})])
def test_a_hexa_allocates_each_torque_exactly_to_the_right_rotors(torque, more):
    """+roll: the left rotors (azimuths -90, -30, -150) push more; +pitch: the front ones (30, -30); +yaw: the
    CCW ones. What the six thrusts give back, summed by hand from their places, is the demand exactly."""
    thrusts = Mixer(HEXA_VEHICLE).rotor_thrusts(9.80665, np.array(torque))
    assert set(np.flatnonzero(thrusts > 9.80665 / 6 + 1e-9)) == more
    x = [0.25 * math.cos(math.radians(az)) for az, _ in HEXA]
    y = [0.25 * math.sin(math.radians(az)) for az, _ in HEXA]
    ccw = [1.0 if spin == "ccw" else -1.0 for _, spin in HEXA]
    given = (sum(thrusts), sum(-yi * t for yi, t in zip(y, thrusts, strict=True)),
             sum(xi * t for xi, t in zip(x, thrusts, strict=True)),
             sum(0.016 * c * t for c, t in zip(ccw, thrusts, strict=True)))
    assert given == pytest.approx((9.80665, *torque), abs=1e-12)


def test_a_hexa_says_so_in_its_heartbeat_and_its_throttle_counts_six_rotors():
    """MAVLink's MAV_TYPE: 2 quadrotor, 13 hexarotor, 14 octorotor. A hover's collective (9.80665 N) out of six
    rotors of 5 N each is 32.7 % throttle (out of four it would read 49 %)."""
    assert (vehicle_type(4), vehicle_type(6), vehicle_type(8)) == (2, 13, 14)
    assert collective_fraction(9.80665, HEXA_VEHICLE) == pytest.approx(9.80665 / 30)


def test_a_quad_x_given_by_azimuths_mixes_bit_for_bit_as_the_closed_form():
    """Positions written as arm·cos(45°) differ from arm/√2 in the last bit; the mixer takes the closed form for
    them, so that quad flights stay bit for bit what they were before it took a layout."""
    a = 0.25 / math.sqrt(2)
    closed = np.vstack((np.ones(4), -a * np.array((1.0, -1.0, -1.0, 1.0)), a * np.array((1.0, -1.0, 1.0, -1.0)),
                        0.016 * np.array((1.0, 1.0, -1.0, -1.0))))
    assert VEHICLE.rotors[0].position_frd_m[0] != a  # cos 45° at 0.25 m
    assert np.array_equal(Mixer(VEHICLE)._inverse, np.linalg.inv(closed))


def test_differentiator_recovers_first_and_second_derivatives_of_a_sine():
    d = ThirdOrderDifferentiator(100.0, size=1)
    dt, w = 0.001, 2.0
    for k in range(5000):
        t = k * dt
        _, d1, d2 = d.update(np.array([math.sin(w * t)]), dt)
    # a triple pole at 100 rad/s lags a 2 rad/s sine by 3 w/100 rad
    lag = 3 * w / 100
    assert d1[0] == pytest.approx(w * math.cos(w * t - lag), abs=0.02)
    assert d2[0] == pytest.approx(-w * w * math.sin(w * t - lag), abs=0.05 * w * w)  # 5 % of the amplitude


def rx(a: float) -> np.ndarray:
    return np.array(((1, 0, 0), (0, math.cos(a), -math.sin(a)), (0, math.sin(a), math.cos(a))))


def ry(a: float) -> np.ndarray:
    return np.array(((math.cos(a), 0, math.sin(a)), (0, 1, 0), (-math.sin(a), 0, math.cos(a))))


def rz(a: float) -> np.ndarray:
    return np.array(((math.cos(a), -math.sin(a), 0), (math.sin(a), math.cos(a), 0), (0, 0, 1)))


def test_estimator_aligns_attitude_and_heading_from_accel_and_mag_at_rest():
    roll, pitch, yaw = 0.05, -0.08, 1.2
    field_ned = np.array((21.5e-6, 1.3e-6, 43.3e-6))
    rot = rz(yaw) @ ry(pitch) @ rx(roll)  # body FRD -> NED for ZYX angles, from elementary rotations by hand
    est = Estimator(EstimatorSettings())
    est.on_gps(GpsFix(0, 47.397742, 8.545594, 488.0, (0, 0, 0), 0.5, 0.5), 0)
    est.field_ned = field_ned  # the test's field, so the check does not depend on the WMM
    f = tuple(rot.T @ np.array((0.0, 0.0, -9.80665)))
    m = tuple(rot.T @ field_ned)
    for k in range(10):
        est.on_sensors(SensorReadings(k * 4000, f, (0.0, 0.0, 0.0), m))
    assert est.estimate().eta == pytest.approx((roll, pitch, yaw), abs=1e-3)


def test_the_estimators_history_answers_for_the_sample_nearest_a_time_within_its_last_second():
    """The state a GPS fix is compared with: the sample nearest its measurement time (the older of two equally
    near), from the last HISTORY_S = 1 s only, however many samples that is (here 1 kHz: the history grows past
    its first size while it runs), plus the corrections applied since."""
    field_ned = np.array((21.5e-6, 1.3e-6, 43.3e-6))
    est = Estimator(EstimatorSettings())
    est.on_gps(GpsFix(0, 47.397742, 8.545594, 488.0, (0, 0, 0), 0.5, 0.5), 0)
    est.field_ned = field_ned
    rng = np.random.default_rng(3)
    seen: list[tuple[int, np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []
    t_us = 0
    for k in range(2500):  # 2.5 s, with a 2 ms gap every 100 samples: some times are equally near two samples
        t_us += 2000 if k % 100 == 99 else 1000
        accel = (rng.normal(0, 0.3), rng.normal(0, 0.3), -9.80665 + rng.normal(0, 0.3))
        est.on_sensors(SensorReadings(t_us, accel, tuple(rng.normal(0, 0.01, 3)), tuple(field_ned)))
        est._pending_pos += rng.normal(0, 0.01, 3)  # corrections to apply, as fixes leave them
        seen.append((t_us, est.pos.copy(), est.vel.copy(), est._applied_pos.copy(), est._applied_vel.copy()))
    kept = [s for s in seen if s[0] >= t_us - 1_000_000]
    assert len(kept) > HISTORY_START  # more than the history's first size: it grew
    for target in (t_us - 5_000_000, t_us - 999_500, t_us - 500_000, seen[-102][0] + 1000, t_us, t_us + 10_000):
        _, pos, vel, applied_pos, applied_vel = min(kept, key=lambda s: abs(s[0] - target))  # first of equals
        state = est._state_at(target)
        assert state is not None
        assert np.array_equal(state[0], pos + (est._applied_pos - applied_pos))
        assert np.array_equal(state[1], vel + (est._applied_vel - applied_vel))
    tie = seen[-102][0] + 1000  # halfway between the two samples around a 2 ms gap
    assert abs(seen[-102][0] - tie) == abs(seen[-101][0] - tie)
