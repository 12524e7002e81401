"""The flight itself is judged, with or without `expect`: a vehicle that never leaves the ground, tumbles
or hits the ground fails with the reason and the mission time; a non-finite input names its variable."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import pytest
from mcap.reader import make_reader

from plant_fmu.plant import Plant, PlantError
from tests.support.summary_text import summary_field

pytestmark = pytest.mark.e2e  # drives the bench's processes (hil, the emulator) end to end

ROOT = Path(__file__).resolve().parent.parent


def fly(tmp_path: Path, body: str) -> tuple[int, str, list[str]]:
    scenario = tmp_path / "s.yaml"
    scenario.write_text(body)
    runs = tmp_path / "runs"
    result = subprocess.run([sys.executable, "-m", "hil", "run", "--no-report", "--no-gcs", "--no-telemetry",
                             str(scenario), "--runs", str(runs)], capture_output=True, text=True, cwd=ROOT, timeout=180)
    assert "Traceback" not in result.stderr
    (run_dir,) = runs.iterdir()
    with open(run_dir / "recording.mcap", "rb") as f:  # the indexed reader opens it: the file was closed
        events = [m.data.decode() for _, _, m in make_reader(f).iter_messages(topics=["hil/events"])]
    return result.returncode, (run_dir / "summary.txt").read_text(), events


def test_a_vehicle_whose_flight_code_never_lifts_it_fails_without_any_expect(tmp_path):
    # the board believes the vehicle weighs 0.2 kg: sliding mode PID asks for a fifth of the thrust it needs
    code, summary, events = fly(tmp_path, "name: nolift\nduration_s: 5\nreference: {type: hover, altitude_m: 3}\n"
                                          "end: disarm\nboard: {controller: smpid, config: {vehicle: {mass: 0.2}}}\n")
    assert code == 1
    ended = summary_field(summary, "ended")
    assert ended.startswith("ended: the vehicle never left the ground") and "mission time 0.0" in ended
    assert any("never left the ground" in e for e in events)


def test_a_dead_rotor_tumbles_the_vehicle_and_the_run_says_when(tmp_path):
    code, summary, events = fly(tmp_path, "name: dead\nduration_s: 10\nreference: {type: hover, altitude_m: 5}\n"
                                          "end: disarm\nfaults: {motors: [{motor: 1, start_s: 2, health: 0.0}]}\n")
    assert code == 1
    ended = summary_field(summary, "ended")
    assert ended.startswith("ended: the vehicle tumbled at mission time")
    t = float(ended.split("tumbled at mission time ")[1].split(" s")[0])
    # a quad-X that loses a rotor rolls over within about a second: physics, not a tuned bound
    assert 2.0 < t < 3.5
    assert any("tumbled" in e for e in events)


def test_a_non_finite_input_names_its_variable():
    with Plant() as plant:
        inputs = [0.0] * len(plant.input_names)
        inputs[plant.input_names.index("f_dist_e")] = math.nan
        with pytest.raises(PlantError, match="variable f_dist_e"):
            plant.set_inputs(inputs)
            plant.step(0.004)


def test_a_downdraught_stronger_than_the_rotors_brings_it_down_and_the_run_fails(tmp_path):
    # 30 N down from 2 s to 4 s against 4 × 5 N of thrust less 9.8 N of weight: it must sink from 3 m
    code, summary, events = fly(tmp_path, "name: down\nduration_s: 15\nreference: {type: hover, altitude_m: 3}\n"
                                          "end: disarm\n"
                                          "disturbance: {force_ned: [0, 0, '30*step(t - 2)*step(4 - t)']}\n")
    ended = summary_field(summary, "ended")
    assert code == 1, summary
    assert ended.startswith("ended: the vehicle hit the ground at mission time"), ended
    assert 2.0 < float(ended.split("mission time ")[1].split(" s")[0]) < 4.5  # while the force pushed
    assert any("hit the ground" in e for e in events)
