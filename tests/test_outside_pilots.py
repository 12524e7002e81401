"""Someone else flies PX4 while the bench is only the world (`pilot: external`): PX4's own MAVSDK test cases
(tests/support/mavsdk_pilot.py: their steps, criteria and timeouts) on PX4 SITL, where the bench leaves PX4's API
instance to MAVSDK and its GCS instance to a ground station, and on PX4's HITL path, where the bench's relay serves
both. On SITL each client writes to its instance's own port (px4-rc.mavlink: 14580+N, 18570+N), which takes the
first client that writes as its partner, rather than listening where PX4 sends before that (14540+N, 14550): every
other run's relay sends there too by default, as system 1, and a client listening there answered the last sender.
The bench judges the same flight on the truth (`expect:`), and its verdicts must agree with the script's. One
flight per case and board kind, several criteria each.

Needs HIL_PX4_DIR (tests/support/px4_builds.py).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.support.mavsdk_pilot import Findings, fly_blocking
from tests.support.outside_pilot_runs import (
    SPEED_FACTOR,
    SecondGroundStation,
    assert_the_square_flight,
    finish,
    fly_through_the_relay,
    px4_instance,
    scenario,
    square_items,
    square_mission_with_a_second_station,
    start_bench,
    takeoff_offboard_and_land,
    true_rest_from_home_m,
    verdicts,
)
from tests.support.px4_builds import px4_build, px4_root

PX4_ROOT = px4_root()
pytestmark = [pytest.mark.px4, pytest.mark.slow]


@pytest.fixture(scope="module")
def sitl(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return px4_build(PX4_ROOT, "sitl", tmp_path_factory.mktemp("px4"))


@pytest.fixture(scope="module")
def hitl(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return px4_build(PX4_ROOT, "hitl", tmp_path_factory.mktemp("px4"))


def test_mavsdk_takes_off_flies_offboard_setpoints_and_lands_px4_sitl(sitl, tmp_path):
    expect = {"home_within_m": 1.0, "modes_seen": ["AUTO.TAKEOFF", "OFFBOARD", "AUTO.LAND"], "max_altitude_m": 6.0,
              "disarmed_by_s": 180}
    bench = start_bench(scenario(tmp_path, "mavsdk_offboard", expect), tmp_path / "runs", "--px4", str(sitl),
                        "--speed-factor", str(SPEED_FACTOR))
    findings = Findings()
    try:
        url = f"udpout://127.0.0.1:{14580 + px4_instance(tmp_path / 'runs')}"
        findings = fly_blocking(url, takeoff_offboard_and_land, 600, bench)
    finally:
        out, run_dir = finish(bench, findings)
    assert findings.failures == [], findings
    assert "result: PASS" in out, out
    judged = verdicts(run_dir)
    assert all(v["met"] for v in judged.values()) and set(judged) == set(expect), judged
    assert true_rest_from_home_m(run_dir) < 1.0  # check_home_within(1.0), on the truth
    assert len(findings.offboard_errors_m) == 4 + 1 and max(findings.offboard_errors_m) < 0.3
    assert findings.takeoff_altitude_m is not None and findings.hover_altitude_m is not None
    assert abs(findings.hover_altitude_m - findings.takeoff_altitude_m) <= 0.1 * findings.takeoff_altitude_m


def test_mavsdk_flies_a_square_mission_with_rtl_while_a_second_station_is_served_px4_sitl(sitl, tmp_path):
    expect = {"mission_completed": True, "home_within_m": 2.0, "max_cross_track_m": 5.0,
              "modes_seen": ["AUTO.MISSION", "AUTO.RTL"], "disarmed_by_s": 180}
    runs = tmp_path / "runs"
    bench = start_bench(scenario(tmp_path, "mavsdk_square", expect, square_items()), runs, "--px4", str(sitl),
                        "--speed-factor", str(SPEED_FACTOR))
    findings = Findings()
    try:
        instance = px4_instance(runs)
        station = SecondGroundStation(f"udpout:127.0.0.1:{18570 + instance}", instance + 1)
        station.start()
        findings = fly_blocking(f"udpout://127.0.0.1:{14580 + instance}", square_mission_with_a_second_station(station),
                                900, bench)
    finally:
        out, run_dir = finish(bench, findings)
    assert_the_square_flight(findings, station, out, run_dir)


def test_mavsdk_and_a_second_station_fly_px4_hitl_through_the_relay(hitl, tmp_path):
    """On PX4's HITL path the bench holds the board's only link: its relay serves MAVSDK and a ground station on
    two ports at once. One flight: take-off, the offboard setpoints, then the square mission with RTL."""
    fly_through_the_relay(tmp_path, "--px4-hitl", str(hitl))
