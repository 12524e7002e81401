"""A plant of one's own on the bench, through `hil run` and `hil check` as a user types them: the foreign pythonfmu
quadrotor (tests/data/foreign_plant: its own names, ENU, FLU, degrees, rpm, PWM) and our hexa X flown on the
emulator through their mapping files only, and each wrong mapping refused in one line before any board starts.

A pythonfmu plant runs Python at every doStep (~1.5 ms a bench step), so the flights here are short scenarios
written for the test; the shipped scenarios were compared once, in full (docs/plant.md).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from mcap.reader import make_reader

from tests.support.cli_runs import ROOT, run
from tests.test_foreign_plant import WRONG

pytestmark = pytest.mark.e2e

# A gusty hover, as scenarios/gust.yaml but 3 m up for 8 s: crosswind, light turbulence, one gust across.
SHORT_GUST = """name: short_gust
duration_s: 8
seed: 7
reference: {type: hover, altitude_m: 3, yaw_deg: 90}
wind:
  steady_ned: [0.0, 3.0, 0.0]
  gusts: [{start_s: 2, duration_s: 2.0, peak_ned: [0.0, 3.0, 0.0]}]
  turbulence: {intensity: light, altitude_m: 3, airspeed_m_s: 3.0}
expect: {max_error_m: [1.2, 1.2, 0.5], max_attitude_error_deg: 5}
"""
# Our FMU without its rotor aerodynamics (the foreign plant has none): the two plants are then the same vehicle.
AERO_OFF = ("vehicle: {induced_inflow_coeff: 0, rotor_drag_coeff: 0, parasitic_drag_area_x: 0, "
            "parasitic_drag_area_y: 0, parasitic_drag_area_z: 0}\n")


def short_gust(tmp_path: Path, vehicle: str = "") -> Path:
    path = tmp_path / f"short_gust_{len(list(tmp_path.glob('short_gust_*')))}.yaml"
    path.write_text(SHORT_GUST + vehicle)
    return path


def recorded(run_dir: Path, topic: str) -> list[dict[str, Any]]:
    with open(run_dir / "recording.mcap", "rb") as f:
        return [json.loads(m.data) for _, _, m in make_reader(f).iter_messages(topics=[topic])]


def mission_positions(run_dir: Path) -> dict[int, np.ndarray]:
    return {s["t_us"]: np.array(s["pos_ned"]) for s in recorded(run_dir, "hil/state") if s["phase"] == "mission"}


def hil(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "hil", *args], capture_output=True, text=True, cwd=ROOT, timeout=120)


def wrong_cases(foreign_mapping: Path, tmp_path: Path) -> dict[Path, str]:
    """Each wrong mapping of the foreign plant (tests/test_foreign_plant.py's), and its right mapping against a
    hexa airframe, as a scenario naming it: scenario file -> the text of its one line."""
    right = yaml.safe_load(foreign_mapping.read_text())
    cases = {}
    for index, (edit, says) in enumerate(WRONG.values()):
        spec = json.loads(json.dumps(right))
        edit(spec)
        mapping = foreign_mapping.with_name(f"wrong_{index}.yaml")  # beside the FMU, which it names relatively
        mapping.write_text(yaml.safe_dump(spec))
        scenario = tmp_path / f"wrong_{index}.yaml"
        scenario.write_text(f"name: wrong\nduration_s: 5\nplant: {mapping}\n")
        cases[scenario] = says
    hexa = tmp_path / "quad_on_hexa.yaml"
    hexa.write_text(f"name: wrong\nduration_s: 5\nvehicle: {{preset: inspection_hexa}}\nplant: {foreign_mapping}\n")
    cases[hexa] = "rotors.list: 4 rotors mapped, the board's airframe inspection_hexa has 6"
    return cases


def test_each_wrong_mapping_is_one_line_from_hil_check_and_hil_run_and_no_board_starts(foreign_mapping, tmp_path):
    cases = wrong_cases(foreign_mapping, tmp_path)
    checked = hil("check", *map(str, cases))
    assert checked.returncode == 2 and checked.stdout == "" and "Traceback" not in checked.stderr
    for scenario, says in cases.items():
        lines = [line for line in checked.stderr.splitlines() if line.startswith(f"{scenario}:")]
        assert len(lines) == 1 and says in lines[0], (says, checked.stderr)
    assert len(checked.stderr.splitlines()) == len(cases)
    runs = tmp_path / "runs"
    runs.mkdir()
    for scenario, says in cases.items():
        result = hil("run", str(scenario), "--runs", str(runs), "--no-telemetry")
        assert result.returncode == 2, result.stdout + result.stderr
        assert result.stderr.count("\n") == 1 and says in result.stderr and result.stderr.startswith(str(scenario))
        assert "emulator" not in result.stdout + result.stderr
    assert list(runs.iterdir()) == []  # no run directory: nothing started


def test_the_foreign_quadrotor_flies_a_gusty_hover_as_our_fmu_does(foreign_mapping, tmp_path):
    """The same vehicle modelled twice (our C FMU, RK4 at 1 ms; their Python, Heun at 2 ms, ENU/FLU through the
    mapping) under the same sensors, seed and wind: SMARC flies both, and the two true trajectories stay within
    5 cm of each other through the gust (flown here: 5 mm apart at most, while the GPS noise the estimator follows
    moves both ~0.3 m, alike). A sign or a unit mapped wrong would part them by metres, or not fly at all."""
    ours, ours_dir = run(short_gust(tmp_path, AERO_OFF), tmp_path / "ours", "--no-report", "--no-telemetry", "--no-gcs")
    theirs, theirs_dir = run(short_gust(tmp_path), tmp_path / "theirs", "--plant", str(foreign_mapping), "--no-report",
                             "--no-telemetry", "--no-gcs")
    assert ours.returncode == 0 and theirs.returncode == 0, ours.stdout + theirs.stdout + theirs.stderr
    assert yaml.safe_load((theirs_dir / "scenario.yaml").read_text())["plant"] == str(foreign_mapping)
    a, b = mission_positions(ours_dir), mission_positions(theirs_dir)
    common = sorted(set(a) & set(b))
    assert len(common) > 0.9 * 8 * 250
    gap = max(float(np.linalg.norm(a[t] - b[t])) for t in common)
    assert gap < 0.05, f"the plants' true positions part by {gap:.3f} m"
    motors = recorded(theirs_dir, "hil/actuators")
    assert {len(m["motors"]) for m in motors} == {4}


def test_our_hexa_flies_the_gusty_hover_on_the_emulator_with_all_six_rotors(tmp_path):
    """vehicle.preset inspection_hexa: our FMU's hexa X through its mapping, the emulator's mixer told its six
    rotors (emulator.yaml), six motor commands in each HIL_ACTUATOR_CONTROLS, every rotor carrying load."""
    result, run_dir = run(short_gust(tmp_path, "vehicle: {preset: inspection_hexa}\n"), tmp_path / "runs",
                          "--no-report", "--no-telemetry", "--no-gcs")
    assert result.returncode == 0, result.stdout + result.stderr
    mixer = yaml.safe_load((run_dir / "emulator.yaml").read_text())["vehicle"]["rotors"]
    azimuths = [round(float(np.degrees(np.arctan2(r["position_frd_m"][1], r["position_frd_m"][0])))) for r in mixer]
    assert azimuths == [90, -90, -30, 150, 30, -150]  # PX4's hexa X, airframe 6001's CA_ROTOR0..5
    assert [r["spin"] for r in mixer] == ["cw", "ccw", "cw", "ccw", "ccw", "cw"]
    mission = {s["t_us"] for s in recorded(run_dir, "hil/state") if s["phase"] == "mission"}
    commands = np.array([m["motors"] for m in recorded(run_dir, "hil/actuators") if m["t_us"] in mission])
    assert commands.shape[1] == 6
    # hover by hand: 9.81 N over six 5 N rotors, T = 5 (0.5 u + 0.5 u²) gives u = 0.45 each
    assert np.mean(commands, axis=0) == pytest.approx([0.45] * 6, abs=0.05)
