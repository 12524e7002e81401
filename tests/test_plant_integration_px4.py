"""A plant of one's own with real PX4 v1.15.4 SITL (`--px4`): the foreign pythonfmu quadrotor through its mapping
file, and our hexa X, for which the bench makes PX4 SITL's quad airframe a hexa X by parameters (MAV_TYPE,
CA_ROTOR_COUNT and CA_ROTORi_*, PWM_MAIN_FUNC5/6) at start-up and reads them back before arming. PX4's own flight
log and its HIL_ACTUATOR_CONTROLS say whether it took them: six motors driven. A 70 % loss of one of six rotors is
survived; the same loss on the quad is not.

Needs HIL_PX4_DIR (tests/support/px4_builds.py). The flights are short scenarios written for the test, and
hexa_motor_failure.yaml, which is short itself.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from pyulog import ULog

from tests.test_plant_integration import short_gust
from tests.test_px4 import (
    assert_px4_flew_the_whole_flight,
    flight_log,
    hil_run,
    only_run_dir,
    processes_using,
    recorded,
)

pytestmark = [pytest.mark.px4, pytest.mark.slow]
ROOT = Path(__file__).resolve().parent.parent
HEXA_FAILURE = ROOT / "scenarios" / "hexa_motor_failure.yaml"
MAV_TYPE_HEXAROTOR = 13

SHORT_HOVER = """name: short_hover
duration_s: 6
seed: 1
reference: {type: hover, altitude_m: 3}
"""


def px4_log(run_dir: Path, topics: list[str]) -> ULog:
    (log,) = sorted((run_dir / "px4" / "log").rglob("*.ulg"))
    return ULog(str(log), topics)


def test_the_foreign_quadrotor_flies_a_hover_with_px4_sitl(sitl, foreign_mapping, tmp_path):
    scenario = tmp_path / "short_hover.yaml"
    scenario.write_text(SHORT_HOVER)
    result = hil_run(str(scenario), "--px4", str(sitl), "--plant", str(foreign_mapping), "--no-report",
                     runs=tmp_path / "runs")
    assert result.returncode == 0, result.stdout + result.stderr
    run_dir = only_run_dir(tmp_path / "runs")
    assert_px4_flew_the_whole_flight(flight_log(run_dir))
    assert not processes_using(run_dir)


def test_px4_sitl_becomes_a_hexa_x_by_parameters_and_flies_our_hexa_through_a_gust(sitl, tmp_path):
    """The bench sets the hexa on PX4 SITL's airframe 10016 (a quad) in its start-up and reads each parameter
    back before arming: PX4's log has them from the start, its vehicle type a hexarotor, its control allocation's
    actuator_motors driving six motors in flight, and each of the six commands it sends carries load."""
    hexa = short_gust(tmp_path, "vehicle: {preset: inspection_hexa}\n")
    result = hil_run(str(hexa), "--px4", str(sitl), "--no-report", runs=tmp_path / "runs")
    assert result.returncode == 0, result.stdout + result.stderr
    run_dir = only_run_dir(tmp_path / "runs")
    ulog = px4_log(run_dir, ["actuator_motors", "vehicle_status", "vehicle_land_detected", "vehicle_command_ack"])
    start = ulog.initial_parameters
    assert (start["CA_ROTOR_COUNT"], start["MAV_TYPE"]) == (6, MAV_TYPE_HEXAROTOR)
    assert (start["PWM_MAIN_FUNC5"], start["PWM_MAIN_FUNC6"]) == (105, 106)
    assert start["CA_ROTOR0_PY"] == pytest.approx(0.25) and start["CA_ROTOR0_KM"] == pytest.approx(-0.05)
    assert MAV_TYPE_HEXAROTOR in set(ulog.get_dataset("vehicle_status").data["system_type"])
    motors = ulog.get_dataset("actuator_motors").data
    flying = np.array([motors[f"control[{i}]"] for i in range(6)])[:, motors["control[0]"] > 0.2]
    assert flying.shape[1] > 100 and np.all(np.isfinite(flying))
    assert np.all(np.median(flying, axis=1) > 0.2)  # all six rotors carry the vehicle
    sent = np.array([m["motors"] for m in recorded(run_dir, "hil/actuators") if m["armed"]])
    assert sent.shape[1] == 6 and np.all(np.median(sent, axis=0) > 0.2)  # and PX4's outputs drive all six
    assert_px4_flew_the_whole_flight(flight_log(run_dir))


def test_px4_survives_a_rotor_losing_70_percent_on_the_hexa_and_not_on_the_quad(sitl, tmp_path):
    """hexa_motor_failure.yaml as shipped, and the same flight on the quad (vehicle preset inspection_quad): the
    quad's rotor 1 then gives at most 1.5 N where a balanced hover needs 2.45 N from each rotor."""
    hexa = hil_run(str(HEXA_FAILURE), "--px4", str(sitl), "--no-report", runs=tmp_path / "hexa")
    assert hexa.returncode == 0, hexa.stdout + hexa.stderr
    run_dir = only_run_dir(tmp_path / "hexa")
    assert json.loads((run_dir / "metrics.json").read_text())["phase_reached"] == "done"
    sent = np.array([m["motors"] for m in recorded(run_dir, "hil/actuators") if m["armed"]])
    assert np.all(np.median(sent, axis=0) > 0.2)  # all six rotors were flown
    quad = tmp_path / "quad_motor_failure.yaml"
    spec = yaml.safe_load(HEXA_FAILURE.read_text())
    quad.write_text(yaml.safe_dump({**spec, "name": "quad_motor_failure", "vehicle": {"preset": "inspection_quad"}}))
    lost = hil_run(str(quad), "--px4", str(sitl), "--no-report", runs=tmp_path / "quad")
    assert lost.returncode == 1, lost.stdout + lost.stderr
    reason = json.loads((only_run_dir(tmp_path / "quad") / "metrics.json").read_text())["reason"]
    assert "hit the ground" in reason or "tumbled" in reason, reason
