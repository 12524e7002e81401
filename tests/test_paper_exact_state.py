"""The exact-state path (issue 18): with `state_source: truth` the emulator's controller flies on the plant's
state at float32 precision (ODOMETRY), and the paper's studies through the chain then give the attitude errors
the controller classes give in process on the exact state."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from pymavlink.dialects.v20 import common

from firmware_interface import hil_codec as codec
from firmware_interface import hil_frames
from firmware_interface.emulator.config import build_config
from firmware_interface.emulator.truth import OdometryReader
from hil.reports.plotting import state_index
from hil.reports.rundata import load_flight
from hil.scenario.loader import load_scenario
from tests.support.closed_loop import PAPER_PLANT, fly, helix, scenario_inputs

pytestmark = pytest.mark.e2e  # drives the bench's processes (hil, the emulator) end to end

ROOT = Path(__file__).resolve().parent.parent
FLOAT32_EPS = float(np.finfo(np.float32).eps)  # 1.2e-7: one rounding of a value to float32, relative


def run(scenario: Path, runs: Path, *options: str) -> Path:
    subprocess.run([sys.executable, "-m", "hil", "run", str(scenario), "--runs", str(runs), "--no-telemetry",
                    "--no-report", "--no-gcs", *options], check=False, capture_output=True, cwd=ROOT, timeout=600)
    return next(runs.iterdir())


def test_odometry_carries_the_local_state_as_float32_with_velocity_in_ned():
    truth = codec.LocalTruth(t_us=8000, pos_ned=(1.23456789, -2.5, -38.7654321), vel_ned=(0.987654321, -1.0, 0.005),
                             q_wxyz=(0.9659258, 0.0, 0.0, 0.2588190), rates_frd=(0.1, -0.2, 0.3))
    buffer = np.zeros(512, dtype=np.uint8)
    size = hil_frames.encode_odometry(buffer, 0, 255, 51, truth.t_us, *(np.array(v) for v in (
        truth.pos_ned, truth.vel_ned, truth.q_wxyz, truth.rates_frd)))
    frame = buffer[:size].tobytes()
    message = common.MAVLink(None).parse_char(frame)  # pymavlink checks the frame's checksum
    assert (message.frame_id, message.child_frame_id) == (1, 1)  # MAV_FRAME_LOCAL_NED for pose and velocity
    assert message.estimator_type == 1 and math.isnan(message.pose_covariance[0])  # MAV_ESTIMATOR_TYPE_NAIVE
    assert message.time_usec == truth.t_us
    state = OdometryReader().state(frame)  # what the emulator flies on, read from the frame by compiled code
    decoded = ((message.x, message.y, message.z), (message.vx, message.vy, message.vz),
               (message.rollspeed, message.pitchspeed, message.yawspeed))
    for sent, from_pymavlink, flown in zip((truth.pos_ned, truth.vel_ned, truth.rates_frd), decoded,
                                           (state.pos_ned, state.vel_ned, state.rates_frd), strict=True):
        assert np.array(from_pymavlink) == pytest.approx(np.array(sent, dtype=np.float32), abs=0)
        assert flown.tolist() == list(from_pymavlink)
    assert abs(state.pos_ned[2] - truth.pos_ned[2]) < 4e-6  # 38.8 m at float32: 4 µm, not HIL_STATE's 1 mm
    # a 30 deg yaw, about z: q = (cos 15 deg, 0, 0, sin 15 deg), within float32 rounding
    assert state.eta.tolist() == pytest.approx([0.0, 0.0, math.radians(30.0)], abs=1e-6)


def test_the_controller_flies_on_the_plants_state_to_float32_precision(tmp_path):
    """The emulator reports the state its controller flew on (LOCAL_POSITION_NED, ATTITUDE, each step's before
    the reply); at the same step it equals the plant's to a few float32 roundings. HIL_STATE_QUATERNION would
    have been off by up to ~0.5 cm in position and 0.5 cm/s in velocity."""
    scenario = tmp_path / "exact.yaml"
    scenario.write_text("name: exact\nduration_s: 3\nrate_hz: 250\nvehicle: {preset: paper_airframe}\n"
                        "reference: {type: helix, altitude_m: 3}\nend: disarm\nboard: {state_source: truth}\n"
                        "sensors: {imu: {profile: ideal}, mag: {profile: ideal}, baro: {profile: ideal}, "
                        "gps: {profile: ideal}}\n")
    flight = load_flight(run(scenario, tmp_path / "runs"),
                         ("state", "board/local_position_ned", "board/attitude"))
    t_us = np.array([s["t_us"] for s in flight.samples("state")], dtype=np.int64)
    checked = 0
    for channel, key, truth_key in (("board/local_position_ned", "pos_ned", "pos_ned"),
                                    ("board/local_position_ned", "vel_ned", "vel_ned"),
                                    ("board/attitude", "rpy", "rpy")):
        at = state_index(t_us, np.array([s["t_us"] for s in flight.samples(channel)], dtype=np.int64))
        board = flight.column(channel, key)[at >= 0]
        truth = flight.column("state", truth_key)[at[at >= 0]]
        scale = np.maximum(np.abs(truth), 1.0)
        assert np.abs(board - truth).max() <= 8 * FLOAT32_EPS * scale.max(), channel + " " + key
        checked += len(board)
    assert checked > 3 * 100  # 50 Hz telemetry over the whole flight


def attitude_ranges_in_process(study: str, controller: str) -> dict[str, tuple[float, float]]:
    """Roll and pitch error ranges (deg) after 2 s of the controller class in process on the exact state."""
    scenario = load_scenario(ROOT / "scenarios" / f"{study}.yaml")
    config = build_config({"airframe": "paper_airframe", "controller": controller})
    trace = fly(config, PAPER_PLANT, helix(10.0), scenario.duration_s, dt=0.001, start=(1.0, 0.0, -10.0),
                inputs=scenario_inputs(scenario, 0.001))
    error = np.degrees(trace.eta[trace.t > 2.0] - trace.eta_cmd[trace.t > 2.0])
    return {axis: (float(error[:, i].min()), float(error[:, i].max())) for i, axis in enumerate(("roll", "pitch"))}


def within_twice(chain: tuple[float, float], reference: tuple[float, float]) -> bool:
    """Each end of the range within a factor 2 of the reference's (ends below 0.05° count as 0.05°: the
    50 Hz sampling of the chain's commands resolves no less)."""
    return all(max(abs(c), 0.05) <= 2 * max(abs(r), 0.05) and max(abs(r), 0.05) <= 2 * max(abs(c), 0.05)
               for c, r in zip(chain, reference, strict=True))


@pytest.mark.slow
@pytest.mark.parametrize("controller", ["smarc", "smpid", "backstepping"])
def test_paper_helix_1kg_attitude_errors_through_the_chain_match_the_exact_state_in_process(tmp_path, controller,
                                                                                          shipped_flight):
    study = ROOT / "scenarios" / "paper_helix_1kg.yaml"
    # the shipped file flies SMARC: that flight is the one the shipped-scenario tests judge too
    run_dir = shipped_flight(study)[1] if controller == "smarc" else run(study, tmp_path / "runs", "--controller",
                                                                         controller)
    chain = json.loads((run_dir / "metrics.json").read_text())["attitude_error_deg"]
    exact = attitude_ranges_in_process("paper_helix_1kg", controller)
    for axis in ("roll", "pitch"):
        measured = (chain[axis]["min"], chain[axis]["max"])
        assert within_twice(measured, exact[axis]), f"{axis}: chain {measured}, in process {exact[axis]}"


@pytest.mark.slow
def test_smarc_on_the_papers_study_through_the_chain_matches_an_independent_re_derivation(shipped_flight):
    """Issue 18's re-derivation of §4 on the exact state: γ error [−0.10, +0.54]°, θ [−0.33, +0.21]°, in the
    paper's signs (γ = −roll, θ = −pitch: tests/test_paper_frames.py)."""
    chain = json.loads((shipped_flight(ROOT / "scenarios" / "paper_helix.yaml")[1] / "metrics.json")
                       .read_text())["attitude_error_deg"]
    gamma = (-chain["roll"]["max"], -chain["roll"]["min"])
    theta = (-chain["pitch"]["max"], -chain["pitch"]["min"])
    assert within_twice(gamma, (-0.10, 0.54)), gamma
    assert within_twice(theta, (-0.33, 0.21)), theta
