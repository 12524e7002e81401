"""The limits behind `hil check`, in process: bounded expressions and their errors, bounded output, and the
valid scenarios (shipped, resolved, written by other tests) that the stricter schema must still accept."""

from __future__ import annotations

import math
import re
import time
from collections.abc import Callable
from pathlib import Path

import orjson
import pytest
import yaml

from hil.scenario.expressions import (
    EvaluationError,
    ExpressionError,
    compile_expression,
    echo,
)
from hil.scenario.loader import MAX_PROBLEMS, Problem, ScenarioError, load_scenario
from hil.scenario.schema import Disturbance, Scenario
from hil.scenario.vehicles import PLANT_PRESETS, thrust_to_weight
from hil.sensors import SensorsConfig
from tests.test_plant_integration import AERO_OFF, SHORT_GUST

ROOT = Path(__file__).resolve().parent.parent
SHIPPED = sorted((ROOT / "scenarios").glob("*.yaml"))
# Scenarios other tests write inline (test_compare_report, test_foxglove, test_gcs_relay, test_hil_run,
# test_link_faults, test_link_tlog, test_px4, test_telemetry, test_run_ends_cleanly, test_paper_exact_state,
# test_sweep).
WRITTEN_BY_TESTS = [
    ("name: cmp\nduration_s: 6\nseed: 1\nreference: {type: hover, altitude_m: 3}\nend: disarm\n"
     "payload: [{t_s: 3, mass_kg: 0.3}]\ndisturbance: {force_ned: ['0.3*sin(t)', 0, 0]}\nexpect: {settle_s: 1}\n"),
    ("name: fox\nduration_s: 20.0\nseed: 3\nreference: {type: hover, altitude_m: 3}\n"
     "wind: {steady_ned: [2, 1, 0], turbulence: {intensity: light}}\n"),
    "name: s\nduration_s: 3\nseed: 4\nreference: {type: hover, altitude_m: 2}\n",
    "name: s\nduration_s: 1\nseed: 4\nreference: {type: hover, altitude_m: 2}\nend: disarm\n",
    ("name: payload\nduration_s: 12\nseed: 3\nreference: {type: hover, altitude_m: 3}\n"
     "payload: [{t_s: 5, mass_kg: 0.5}]\n"),
    ("name: short\nduration_s: 120.0\nseed: 4\nreference: {type: hover, altitude_m: 3}\n"
     "wind: {steady_ned: [1, 0, 0], turbulence: {intensity: light}}\n"),
    ("name: lossy\nduration_s: 4\nseed: 5\nreference: {type: hover, altitude_m: 3}\n"
     "faults:\n  link:\n    - {kind: loss, probability: 0.05}\n    - {kind: latency, delay_ms: 2, jitter_ms: 1}\n"
     "expect: {settle_s: 1, max_error_m: 0.8, max_attitude_error_deg: 3}\n"),
    ("name: outage\nduration_s: 8\nseed: 5\nreference: {type: hover, altitude_m: 3}\n"
     "faults:\n  link:\n    - {kind: outage, direction: to_board, start_s: 3, end_s: 4}\n"),
    "name: nofix\nduration_s: 5\nsensors: {gps: {profile: px4_sitl, fix_type: 0}}\n",
    ("name: tele\nduration_s: 0.5\nseed: 2\nreference: {type: hover, altitude_m: 1.0}\n"
     "end: disarm\ntelemetry: {rates_hz: {state: 100, sensors/imu: 25}}\n"),
    "name: hold\nduration_s: 5\nseed: 2\nreference: {type: hover, altitude_m: 3}\n",
    ("name: exact\nduration_s: 3\nrate_hz: 250\nvehicle: {preset: paper_airframe}\n"
     "reference: {type: helix, altitude_m: 3}\nend: disarm\nboard: {state_source: truth}\n"
     "sensors: {imu: {profile: ideal}, mag: {profile: ideal}, baro: {profile: ideal}, gps: {profile: ideal}}\n"),
    ("name: still\nduration_s: 4\nexpect: {settle_s: 1}\nreference: {type: hover, altitude_m: 2}\nend: disarm\n"
     "sensors: {imu: {profile: ideal}, mag: {profile: ideal}, baro: {profile: ideal}, "
     "gps: {profile: ideal}}\nboard: {state_source: truth}\n"),
    SHORT_GUST, SHORT_GUST + AERO_OFF, SHORT_GUST + "vehicle: {preset: inspection_hexa}\n",  # test_plant_integration
    "name: short_hover\nduration_s: 6\nseed: 1\nreference: {type: hover, altitude_m: 3}\n",  # and its PX4 flights
    # YAML features a scenario may use: anchors, aliases and merge keys, .inf as "until the end"
    ("name: anchors\nduration_s: 30\nwind:\n  gusts:\n    - &gust {start_s: 5, duration_s: 2, peak_ned: [0, 3, 0]}\n"
     "    - {<<: *gust, start_s: 15}\nfaults: {motors: [{motor: 1, start_s: 10, end_s: .inf, health: 0.8}]}\n"),
]


def _timed(action: Callable[[], object]) -> float:
    started = time.perf_counter()
    with pytest.raises(ExpressionError):
        action()
    return time.perf_counter() - started


@pytest.mark.parametrize("text", ["9**9**9", "10**10000000", "+".join(["t"] * 1000), "-" * 1000 + "t",
                                  "-" * 100_000 + "t", "(" * 201 + "t" + ")" * 201, "-(" * 150 + "t" + ")" * 150])
def test_expressions_that_would_compute_forever_or_recurse_are_refused_at_once(text):
    assert _timed(lambda: compile_expression(text)) < 0.1


def test_expressions_compute_in_floats_and_keep_the_papers_disturbance():
    assert compile_expression("floor(t)**2")(3.5) == 9.0 and isinstance(compile_expression("2**3")(0.0), float)
    assert compile_expression("sin(pi*t)")(0.5) == pytest.approx(1.0)
    assert compile_expression("+".join(["0.1*sin(t)"] * 40))(math.pi / 2) == pytest.approx(4.0)  # 40 terms


def test_an_evaluation_error_names_the_expression_its_field_and_the_time():
    force = Disturbance(force_ned=("sin(t)", "1/(t - 5)", 0.0)).functions("force_ned")
    assert force[0](1.0) == pytest.approx(math.sin(1.0))
    with pytest.raises(EvaluationError) as caught:
        force[1](5.0)
    error = caught.value
    assert (error.expression, error.field, error.t) == ("1/(t - 5)", "disturbance.force_ned.1", 5.0)
    assert str(error) == "disturbance.force_ned.1: '1/(t - 5)' fails at t = 5 s: float division by zero"
    with pytest.raises(EvaluationError, match="not a finite number"):
        compile_expression("1e308 * t", "f", sample_times=())(10.0)


def test_output_is_bounded_to_twenty_lines_and_echoed_values_to_80_characters():
    problems = [Problem(Path("f.yaml"), i, f"k{i}", "unknown field") for i in range(5000)]
    lines = str(ScenarioError(problems)).splitlines()
    assert len(lines) == MAX_PROBLEMS and lines[-1] == f"f.yaml: … and {5000 - MAX_PROBLEMS + 1} more problems"
    assert len(echo("x" * 100_000)) == 80 and echo("short") == "'short'"


def test_thrust_to_weight_of_the_presets():
    assert thrust_to_weight({}, 4) == pytest.approx(20 / 9.80665)  # the FMU's defaults: 1 kg, 4 x 5 N
    assert thrust_to_weight(PLANT_PRESETS["paper_airframe"], 4, payload_kg=4.0) == pytest.approx(160 / (5 * 9.80665))
    assert thrust_to_weight(PLANT_PRESETS["inspection_hexa"], 6) == pytest.approx(30 / 9.80665)  # 6 x 5 N


@pytest.mark.parametrize("text", WRITTEN_BY_TESTS, ids=[t.split("\n")[0] for t in WRITTEN_BY_TESTS])
def test_scenarios_written_by_other_tests_still_load(tmp_path, text):
    path = tmp_path / "s.yaml"
    path.write_text(text)
    load_scenario(path)


@pytest.mark.parametrize("path", SHIPPED, ids=[p.stem for p in SHIPPED])
def test_a_resolved_scenario_as_the_run_directory_and_zenoh_hold_it_loads_again(tmp_path, path):
    scenario = load_scenario(path)
    resolved = tmp_path / "scenario.yaml"
    resolved.write_text(yaml.safe_dump(scenario.model_dump(mode="json"), sort_keys=False))
    assert load_scenario(resolved) == scenario
    assert Scenario.model_validate(orjson.loads(orjson.dumps(scenario.model_dump(mode="json")))) == scenario  # Zenoh
    sensors = scenario.sensors.model_dump()  # as the bench revalidates them with the faults added
    assert SensorsConfig.model_validate({**sensors, "faults": []}).gps == scenario.sensors.gps


def test_a_mistake_the_run_would_find_late_is_refused_at_load_and_by_model_validate():
    with pytest.raises(ValueError, match=re.escape("board.config.gains.smarc.c1")):
        Scenario.model_validate({"name": "x", "board": {"config": {"gains": {"smarc": {"c1": math.nan}}}}})
    with pytest.raises(ValueError, match=re.escape("sensors.gps.rate_hz")):
        Scenario.model_validate({"name": "x", "sensors": {"gps": {"rate_hz": 0}}})
    with pytest.raises(ValueError, match=re.escape("payload.0.t_s")):
        Scenario.model_validate({"name": "x", "duration_s": 5, "payload": [{"t_s": 6, "mass_kg": 0.1}]})
