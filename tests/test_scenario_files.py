"""Scenario files: validation with clear errors, the safe expression evaluator, wind and references."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from hil.scenario.expressions import ExpressionError, compile_expression
from hil.scenario.reference import Helix, Patrol, Waypoints
from hil.scenario.wind import FT, KNOT, DrydenTurbulence, one_minus_cosine

ROOT = Path(__file__).resolve().parent.parent
SHIPPED = sorted((ROOT / "scenarios").glob("*.yaml"))


def hil(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "hil", *args], capture_output=True, text=True, cwd=ROOT,
                          timeout=120)


def test_every_shipped_scenario_passes_check():
    names = {p.stem for p in SHIPPED}
    assert {"hover", "gust", "mass_change", "paper_helix", "inspection_patrol", "motor_failure"} <= names
    result = hil("check", *map(str, SHIPPED))
    assert result.returncode == 0, result.stderr
    assert result.stdout.count(": ok (") == len(SHIPPED)


@pytest.mark.parametrize(
    ("text", "line", "field", "says"),
    [
        ("name: x\nduration_s: ten\n", 2, "duration_s", "found 'ten', expected: input should be a valid number"),
        ("name: x\nvehicle:\n  preset: inspection_quad\n  masss: 2\n", 4, "vehicle.masss", "no parameter 'masss'"),
        ("name: x\nvehicle:\n  mass: -1.5\n", 3, "vehicle.mass",
         "found -1.5, expected: input should be greater than 0"),
        ("name: x\ndisturbance:\n  force_ned: ['sin(t)', 'open(1)', 0]\n", 3, "disturbance.force_ned",
         "only calls to sin"),
        ("name: x\nreference:\n  type: spiral\n", 3, "reference", "'spiral'"),
        ("name: x\npayload:\n  - {t_s: 5, mass_kg: -2}\n", 3, "payload.0.mass_kg", "greater than or equal to 0"),
        ("duration_s: 5\n", None, "name", "missing"),
    ],
)
@pytest.mark.slow
def test_malformed_scenarios_exit_2_with_one_clear_line(tmp_path, text, line, field, says):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    result = hil("check", str(path))
    assert result.returncode == 2
    assert "Traceback" not in result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1
    where = f"{path}:{line}: " if line else f"{path}"
    assert lines[0].startswith(where) and f"{field}: " in lines[0] and says in lines[0], lines[0]


@pytest.mark.slow
def test_missing_file_and_non_yaml_exit_2_without_traceback(tmp_path):
    missing = hil("run", str(tmp_path / "nope.yaml"))
    assert missing.returncode == 2 and missing.stderr.strip() == f"{tmp_path / 'nope.yaml'}: no such file"
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: [unclosed\nduration_s: 3\n")
    result = hil("check", str(bad))
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert result.stderr.startswith(f"{bad}:") and "not valid YAML" in result.stderr
    listing = tmp_path / "list.yaml"
    listing.write_text("- a\n- b\n")
    assert "expected a mapping" in hil("check", str(listing)).stderr


def test_expressions_compute_the_papers_disturbance_and_refuse_code():
    d_x, d_z = compile_expression("sin(pi*t)"), compile_expression("-cos(pi*t)")
    assert d_x(0.5) == pytest.approx(1.0) and d_z(1.0) == pytest.approx(1.0)
    assert compile_expression("step(t - 5) * 2")(6.0) == 2.0 and compile_expression(3)(1.0) == 3.0
    for bad in ("__import__('os').system('true')", "t.real", "[1][0]", "x + 1", "lambda: 1", "'a' * 3", "1/t"):
        with pytest.raises(ExpressionError):
            compile_expression(bad)


def test_one_minus_cosine_gust_shape():
    assert one_minus_cosine(9.9, 10, 2) == 0 and one_minus_cosine(12.1, 10, 2) == 0
    assert one_minus_cosine(11.0, 10, 2) == pytest.approx(1.0)
    assert one_minus_cosine(10.5, 10, 2) == pytest.approx(0.5)


@pytest.mark.slow
def test_dryden_intensity_and_scale_follow_mil_f_8785c():
    """At h = 10 m (32.8 ft), light turbulence: σ_w = 0.1·15 kt, σ_u = σ_w/(0.177 + 0.000823 h)^0.4."""
    h_ft = 10.0 / FT
    sigma_w = 0.1 * 15 * KNOT
    sigma_u = sigma_w / (0.177 + 0.000823 * h_ft) ** 0.4
    airspeed = 50.0  # correlation times L/V of ~1.3 s: 1200 s hold ~900 of them (std error ~3 %)
    dryden = DrydenTurbulence(15 * KNOT, 10.0, airspeed, 0.0, 0.004, np.random.default_rng(3))
    assert (dryden.sigma_w, dryden.sigma_u) == pytest.approx((sigma_w, sigma_u))
    samples = np.array([dryden.sample() for _ in range(300_000)])
    assert samples[:, 0].std() == pytest.approx(sigma_u, rel=0.10)
    assert samples[:, 1].std() == pytest.approx(sigma_u, rel=0.10)
    assert samples[:, 2].std() == pytest.approx(sigma_w, rel=0.10)
    lag = int(dryden.length_u / airspeed / 0.004)  # one correlation time L/V: the u autocorrelation is e^-1
    u = samples[:, 0] - samples[:, 0].mean()
    assert (u[lag:] @ u[:-lag]) / (u @ u) == pytest.approx(math.exp(-1), abs=0.06)


def test_helix_is_the_papers_after_a_smooth_start():
    helix = Helix(center_ned=(0.0, 0.0, -10.0), ramp_s=2.0)
    start = helix.sample(0.0)
    assert start.pos_ned == pytest.approx((1.0, 0.0, -10.0)) and np.allclose(start.vel_ned, 0.0)
    for t in (3.0, 7.5, 20.0):
        tau = t - 1.0  # after the ramp the reference runs 1 s (half the ramp) behind the paper's clock
        r = helix.sample(t)
        assert r.pos_ned == pytest.approx((math.cos(tau / 2), math.sin(tau / 2), -10.0 - tau))
        assert r.vel_ned == pytest.approx((-0.5 * math.sin(tau / 2), 0.5 * math.cos(tau / 2), -1.0))
        assert r.acc_ned == pytest.approx((-0.25 * math.cos(tau / 2), -0.25 * math.sin(tau / 2), 0.0))
        assert r.yaw == pytest.approx(math.pi / 6)
    eps = 1e-6  # velocity is the derivative of position through the ramp
    for t in (0.3, 1.0, 1.9):
        numeric = (helix.sample(t + eps).pos_ned - helix.sample(t - eps).pos_ned) / (2 * eps)
        assert helix.sample(t).vel_ned == pytest.approx(numeric, abs=1e-6)


def test_waypoints_rest_to_rest_at_the_peak_speed_and_patrol_faces_the_line():
    route = Waypoints(((0.0, 0.0, -10.0), (30.0, 0.0, -10.0)), speed=3.0)
    speeds = [np.linalg.norm(route.sample(t).vel_ned) for t in np.linspace(0, route.duration_s, 401)]
    assert max(speeds) == pytest.approx(3.0, rel=1e-3) and speeds[0] == 0 and speeds[-1] == pytest.approx(0)
    assert route.sample(route.duration_s).pos_ned == pytest.approx((30.0, 0.0, -10.0))
    patrol = Patrol((0.0, 0.0, 0.0), (40.0, 0.0, 0.0), standoff_m=5.0, altitude_m=12.0)
    first = patrol.sample(0.0)
    assert first.pos_ned == pytest.approx((0.0, 5.0, -12.0))  # 5 m to the right of a northbound line
    assert first.yaw == pytest.approx(-math.pi / 2)  # facing west, towards the line
