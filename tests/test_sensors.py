"""Sensor models: noise statistics, physics at rest and tilted, ISA, WMM, geodesy, delay, seeds, faults."""

from __future__ import annotations

import math
from itertools import pairwise

import numpy as np
import pytest
from pygeomag import GeoMag

from firmware_interface.hil_codec import SensorReadings
from hil.sensors import (
    Home,
    SensorChoice,
    SensorFault,
    SensorsConfig,
    SensorSuite,
    TrueState,
)
from hil.sensors.baro import Barometer, isa_pressure_pa
from hil.sensors.config import BaroConfig, G, GpsConfig, ImuConfig, MagConfig
from hil.sensors.geodesy import geodetic_to_ned, ned_to_geodetic
from hil.sensors.gps import Gps
from hil.sensors.imu import Imu
from hil.sensors.mag import Magnetometer, earth_field_ned
from hil.sensors.noise import BLOCK

LEVEL = np.array([1.0, 0.0, 0.0, 0.0])
REST_F = np.array([0.0, 0.0, -G])
ZERO = np.zeros(3)
N = 100_000


def rest(t_us: int, pos=ZERO, vel=ZERO, q=LEVEL) -> TrueState:
    return TrueState(t_us, np.asarray(pos, float), np.asarray(vel, float), q, ZERO, REST_F)


def quat_from_euler(roll: float, pitch: float, yaw: float) -> np.ndarray:
    cr, sr, cp, sp, cy, sy = (f(a / 2) for a in (roll, pitch, yaw) for f in (math.cos, math.sin))
    return np.array([cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
                     cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy])


@pytest.mark.slow
def test_imu_white_noise_std_equals_density_times_sqrt_rate():
    rate = 250.0
    config = ImuConfig(accel_noise_density=0.00637, gyro_noise_density=0.000873)
    imu = Imu(config, rate, np.random.default_rng(1))
    samples = np.array([sum(imu.sample(REST_F, ZERO), ()) for _ in range(N)])
    std = samples.std(axis=0)
    assert std[:3] == pytest.approx([0.00637 * math.sqrt(rate)] * 3, rel=0.05)
    assert std[3:] == pytest.approx([0.000873 * math.sqrt(rate)] * 3, rel=0.05)
    assert samples[:, :3].mean(axis=0) == pytest.approx([0, 0, -G], abs=4 * 0.1 / math.sqrt(N))


@pytest.mark.slow
def test_mag_and_baro_and_gps_white_noise_levels():
    mag = Magnetometer(MagConfig(noise_density=0.0004e-4, rate_hz=100.0), Home(), np.random.default_rng(2))
    m = np.array([mag.sample(LEVEL) for _ in range(N)])
    assert m.std(axis=0) == pytest.approx([0.0004e-4 * 10.0] * 3, rel=0.05)
    baro = Barometer(BaroConfig(noise_pa=1.2), np.random.default_rng(3))
    p = np.array([baro.sample(0.0, 488.0).pressure_pa for _ in range(N)])
    assert p.std() == pytest.approx(1.2, rel=0.05)
    gps = Gps(GpsConfig(rate_hz=10.0, vel_noise=0.05, pos_white_noise_xy=0.3), Home(), np.random.default_rng(4))
    fixes = [gps.step(k * 100_000, ZERO, ZERO) for k in range(N)]
    vel = np.array([f.vel_ned for f in fixes])
    north = np.array([geodetic_to_ned(f.lat_deg, f.lon_deg, f.alt_msl_m, Home())[0] for f in fixes[:20_000]])
    assert vel.std(axis=0) == pytest.approx([0.05] * 3, rel=0.05)
    assert north.std() == pytest.approx(0.3, rel=0.05)


def test_bias_random_walk_grows_like_sqrt_t():
    rate, walk = 250.0, 3e-4
    imu = Imu(ImuConfig(accel_bias_random_walk=walk), rate, np.random.default_rng(5))
    x = np.array([imu.sample(REST_F, ZERO)[0][0] for _ in range(N)])  # no white noise: output - truth = bias
    # std of b(t + τ) - b(t) = walk·√τ; lags short enough for >1500 independent windows (≤ 2 % error)
    for lag in (1, 4, 16, 64):
        increments = x[lag:] - x[:-lag]
        assert increments.std() == pytest.approx(walk * math.sqrt(lag / rate), rel=0.05)


def test_imu_quantises_and_saturates_like_the_int16_fifo():
    lsb = G / 2048
    imu = Imu(ImuConfig(accel_lsb=lsb, gyro_lsb=math.radians(2000) / 32768), 250.0, np.random.default_rng(0))
    accel, gyro = imu.sample(np.array([0.1234, 30 * G, -9.81]), np.array([0.001, -50.0, 0.0]))
    assert accel[0] == pytest.approx(round(0.1234 / lsb) * lsb) and accel[0] != 0.1234
    assert accel[1] == pytest.approx(16 * G)  # ±16 g full scale
    assert gyro[1] == pytest.approx(-math.radians(2000), rel=1e-3)  # ±2000 °/s


def test_imu_on_a_multirotor_reads_thrust_not_gravity_at_any_attitude(fmu_path):
    """Hovering tilted, the accelerometer measures only non-gravitational force: (0, 0, -T/m)."""
    from plant_fmu import Plant

    params = {"init_pos_d": -100.0, "drag_coeff_x": 0.0, "drag_coeff_y": 0.0, "drag_coeff_z": 0.0}
    with Plant(params, fmu_path) as plant:
        u = np.zeros(len(plant.input_names))
        for i in range(1, 5):
            u[plant.input_index[f"motor_cmd_{i}"]] = 0.6
            u[plant.input_index[f"motor_health_{i}"]] = 1.0
        u[plant.input_index["tau_dist_x"]] = 0.02  # roll it over while thrusting
        u[plant.input_index["tau_dist_y"]] = -0.01
        plant.set_inputs(u)
        for _ in range(150):
            out = plant.step(0.004)
        o = plant.output_index
        assert abs(out[o["roll"]]) > 0.3 and abs(out[o["pitch"]]) > 0.1
        truth = TrueState(0, ZERO, ZERO, out[[o["q_w"], o["q_x"], o["q_y"], o["q_z"]]],
                          out[[o["rate_x"], o["rate_y"], o["rate_z"]]],
                          out[[o["specific_force_x"], o["specific_force_y"], o["specific_force_z"]]])
        accel, _ = Imu(ImuConfig(), 250.0, np.random.default_rng(0)).sample(truth.specific_force_frd, truth.rates_frd)
        assert accel == pytest.approx((0.0, 0.0, -out[o["thrust_total"]] / 1.0), abs=1e-9)


def test_mag_is_the_earth_field_rotated_into_the_body():
    config = MagConfig(declination_deg=0.0, inclination_deg=60.0, intensity_t=50e-6)
    mag = Magnetometer(config, Home(), np.random.default_rng(0))
    horizontal, vertical = 50e-6 * 0.5, 50e-6 * math.sqrt(3) / 2
    assert mag.sample(LEVEL) == pytest.approx((horizontal, 0.0, vertical))
    # heading east: magnetic north is on the left wing (-y)
    assert mag.sample(quat_from_euler(0, 0, math.pi / 2)) == pytest.approx((0.0, -horizontal, vertical), abs=1e-12)
    # rolled 90° right: the downward field points out of the left wing... body y = -down component
    assert mag.sample(quat_from_euler(math.pi / 2, 0, 0)) == pytest.approx((horizontal, vertical, 0.0), abs=1e-12)


def test_wmm_field_at_px4_default_home_matches_the_published_field():
    """Reference: the Zurich field PX4's jMAVSim uses (docs/px4_protocol.md §3):
    (0.21506, 0.01021, 0.42974) G, i.e. 0.4806 G, inclination 63.4°, declination 2.7°."""
    b = earth_field_ned(MagConfig(epoch_year=2026.0), Home()) * 1e4  # gauss
    published = np.array([0.21506, 0.01021, 0.42974])
    intensity = np.linalg.norm(b)
    inclination = math.degrees(math.atan2(b[2], math.hypot(b[0], b[1])))
    declination = math.degrees(math.atan2(b[1], b[0]))
    assert intensity == pytest.approx(np.linalg.norm(published), rel=0.02)
    assert inclination == pytest.approx(math.degrees(math.atan2(published[2], math.hypot(*published[:2]))), abs=1.0)
    assert declination == pytest.approx(math.degrees(math.atan2(published[1], published[0])), abs=1.0)


def test_the_wmm_package_reproduces_noaa_official_test_values():
    """WMM2015 report test values (2015.0, height 0): the package is a faithful WMM."""
    geomag = GeoMag(coefficients_file="wmm/WMM_2015.COF")
    r = geomag.calculate(glat=80, glon=0, alt=0, time=2015.0)
    assert (r.x, r.y, r.z) == pytest.approx((6627.1, -445.9, 54432.3), abs=0.1)
    r = geomag.calculate(glat=-80, glon=240, alt=0, time=2015.0)
    assert (r.d, r.i) == pytest.approx((69.81, -72.39), abs=0.01)


def test_baro_reads_isa_pressure_at_488_m():
    # by hand: 101325 * (1 - 0.0065*488/288.15)^5.25588 = 95 598 Pa = 955.98 hPa (≈ 956, docs/px4_protocol.md §3)
    assert isa_pressure_pa(488.0) / 100 == pytest.approx(955.98, abs=0.01)
    reading = Barometer(BaroConfig(), np.random.default_rng(0)).sample(0.0, 488.0)
    assert reading.pressure_pa / 100 == pytest.approx(955.98, abs=0.01)
    assert reading.temperature_degc == pytest.approx(15 - 0.0065 * 488)
    assert reading.pressure_alt_m == pytest.approx(488.0, abs=1e-6)


def test_ned_geodetic_round_trip_within_1mm_over_10km():
    home = Home()
    for n, e, d in [(10_000, 0, 0), (0, -10_000, -50), (7071, 7071, -300), (-10_000, 3000, 20)]:
        lat, lon, alt = ned_to_geodetic(n, e, d, home)
        assert geodetic_to_ned(lat, lon, alt, home) == pytest.approx((n, e, d), abs=1e-3)
    lat, _, _ = ned_to_geodetic(1000.0, 0.0, 0.0, home)
    assert (lat - home.lat_deg) * 111_200 == pytest.approx(1000.0, rel=0.01)  # ~111.2 km per degree


def test_gps_delay_is_exactly_the_configured_number_of_bench_steps():
    bench_rate, delay_s = 250.0, 0.12  # 30 bench steps
    gps = Gps(GpsConfig(rate_hz=10.0, delay_s=delay_s), Home(), np.random.default_rng(0))
    deliveries = []
    for k in range(1000):
        pos = np.array([0.5 * k, 0.0, 0.0])  # moving north by 0.5 m per step
        fix = gps.step(int(k * 1e6 / bench_rate), pos, ZERO)
        if fix is not None:
            north = geodetic_to_ned(fix.lat_deg, fix.lon_deg, fix.alt_msl_m, Home())[0]
            deliveries.append((k, round(north / 0.5)))
    assert len(deliveries) > 30
    assert all(k - measured_step == 30 for k, measured_step in deliveries)
    assert all(b[0] - a[0] == 25 for a, b in pairwise(deliveries))  # 10 Hz at 250 Hz


def run_suite(seed: int, steps: int = 2000, config: SensorsConfig | None = None) -> list:
    suite = SensorSuite(config or SensorsConfig(), Home(), 250.0, np.random.default_rng(seed))
    return [suite.step(rest(k * 4000)) for k in range(steps)]


def test_same_seed_same_samples_different_seed_different_noise():
    assert run_suite(42) == run_suite(42)
    a, b = run_suite(42), run_suite(43)
    assert [r.accel_frd for r, _ in a] != [r.accel_frd for r, _ in b]


def test_each_noise_block_is_the_next_draw_of_its_sensors_stream_taken_exactly_when_the_last_is_used_up():
    """The suite's arrays live in two buffers the compiled models read (`SensorSuite.buffers`), each sensor holding a
    view of its part; the models say when a block's last row is taken and only then is the next drawn. After
    BLOCK + 1 steps the IMU (a row a step) holds the second block of its own stream (the first of five spawned from
    the seed), and its cursor has taken one row of it."""
    suite = SensorSuite(SensorsConfig(), Home(), 250.0, np.random.default_rng(7))
    floats, ints = suite.buffers
    assert np.shares_memory(suite.imu.noise.rows, floats) and np.shares_memory(suite.gps.state, ints)
    for k in range(BLOCK + 1):
        suite.step(rest(4000 * (k + 1)))
    imu_stream = np.random.default_rng(7).spawn(5)[0]
    imu_stream.standard_normal(6)  # its turn-on biases
    imu_stream.standard_normal(suite.imu.noise.rows.shape)  # its first block
    assert np.array_equal(suite.imu.noise.rows, imu_stream.standard_normal(suite.imu.noise.rows.shape))
    assert suite.imu.noise.cursor[0] == 1


def test_mag_and_baro_never_exactly_constant_at_rest_in_non_ideal_profiles():
    config = SensorsConfig(imu=SensorChoice(profile="mpu6050"), baro=SensorChoice(profile="ms5611"),
                           gps=SensorChoice(profile="m8n"))
    for cfg in (SensorsConfig(), config):
        out = run_suite(1, 500, cfg)
        mags = [r.mag_frd_t for r, _ in out if r.mag_frd_t]
        baros = [r.baro.pressure_pa for r, _ in out if r.baro]
        assert len(set(mags)) == len(mags) > 100 and len(set(baros)) == len(baros) > 50


def test_rates_of_each_sensor_on_the_bench_clock():
    out = run_suite(0, 2500)  # 10 s at 250 Hz, px4_sitl: mag 100 Hz, baro 50 Hz, GPS 5 Hz
    assert sum(r.mag_frd_t is not None for r, _ in out) == pytest.approx(1000, abs=2)
    assert sum(r.baro is not None for r, _ in out) == pytest.approx(500, abs=1)
    assert sum(g is not None for _, g in out) == pytest.approx(50 - 0.12 * 5, abs=1)
    assert all(r.accel_frd is not None for r, _ in out)


def test_ideal_profiles_are_exact():
    config = SensorsConfig(**{k: SensorChoice(profile="ideal") for k in ("imu", "mag", "baro", "gps")})
    readings, gps = run_suite(0, 1, config)[0]
    assert readings.accel_frd == (0.0, 0.0, -G) and readings.gyro_frd == (0.0, 0.0, 0.0)
    assert gps is not None and (gps.lat_deg, gps.lon_deg) == pytest.approx((Home().lat_deg, Home().lon_deg), abs=1e-12)


def test_faults_dropout_stuck_bias_between_two_times():
    faults = [SensorFault(sensor="accel", kind="bias", start_s=1.0, end_s=2.0, magnitude=0.5),
              SensorFault(sensor="gyro", kind="dropout", start_s=1.0, end_s=2.0),
              SensorFault(sensor="baro", kind="stuck", start_s=1.0, end_s=3.0),
              SensorFault(sensor="gps", kind="dropout", start_s=0.0, end_s=5.0)]
    ideal = {k: SensorChoice(profile="ideal") for k in ("imu", "mag", "gps")}
    out = run_suite(0, 1000, SensorsConfig(**ideal, faults=faults))
    at = lambda t: out[int(t * 250)][0]  # noqa: E731
    assert at(0.5).accel_frd == (0.0, 0.0, -G) and at(1.5).accel_frd == (0.5, 0.5, -G + 0.5)
    assert at(1.5).gyro_frd is None and at(2.5).gyro_frd is not None
    stuck = [r.baro.pressure_pa for r, _ in out[250:750] if r.baro]
    assert len(set(stuck)) == 1 and len({r.baro.pressure_pa for r, _ in out[750:] if r.baro}) > 10
    assert all(g is None for _, g in out)


def test_profile_overrides_are_validated():
    with pytest.raises(ValueError, match="unknown profile 'mpu9250'"):
        SensorSuite(SensorsConfig(imu=SensorChoice(profile="mpu9250")), Home(), 250, np.random.default_rng(0))
    with pytest.raises(ValueError, match="accel_noise_densty"):
        SensorSuite(SensorsConfig(imu=SensorChoice(profile="mpu6050", accel_noise_densty=1)), Home(), 250,
                    np.random.default_rng(0))
    assert isinstance(run_suite(0, 1)[0][0], SensorReadings)


def test_accelerometer_reads_gravity_rotated_into_the_tilted_body_plus_acceleration(fmu_path):
    """f = Rᵀ(a − g·e3), R (body FRD -> NED) written out here from the plant's own quaternion."""
    from plant_fmu import Plant

    with Plant({"init_pos_d": -100.0}, fmu_path) as plant:
        u = np.zeros(len(plant.input_names))
        u[[plant.input_index[f"motor_cmd_{i}"] for i in range(1, 5)]] = 0.55
        u[[plant.input_index[f"motor_health_{i}"] for i in range(1, 5)]] = 1.0
        u[plant.input_index["tau_dist_x"]] = 0.015
        u[plant.input_index["tau_dist_z"]] = 0.01
        plant.set_inputs(u)
        for _ in range(150):
            out = plant.step(0.004)
        o = plant.output_index
        w, x, y, z = (out[o[n]] for n in ("q_w", "q_x", "q_y", "q_z"))
        rot = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
        acc = np.array([out[o[n]] for n in ("acc_n", "acc_e", "acc_d")])
        expected = rot.T @ (acc - np.array([0.0, 0.0, G]))
        force = np.array([out[o[n]] for n in ("specific_force_x", "specific_force_y", "specific_force_z")])
        assert abs(out[o["roll"]]) > 0.2  # clearly tilted (> 11°), and accelerating
        accel, _ = Imu(ImuConfig(), 250.0, np.random.default_rng(0)).sample(force, np.zeros(3))
        assert accel == pytest.approx(tuple(expected), abs=1e-9)
