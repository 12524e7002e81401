"""`hil report` and `hil compare` on real (short) runs, and the z-recovery measure on a hand-made trace."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from pytest import approx

from hil.app.compare import _estimate_rows, _windows
from hil.reports.png import PAPER_FRAME, _name, attitude_error
from hil.reports.rundata import RunData, recovery_times

pytestmark = pytest.mark.e2e  # drives the bench's processes (hil, the emulator) end to end

ROOT = Path(__file__).resolve().parent.parent
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def test_recovery_time_is_when_the_z_error_is_back_under_the_threshold_for_good():
    t = np.arange(0.0, 30.0, 0.01)
    e_z = np.zeros_like(t)
    e_z[(t >= 10) & (t < 11.5)] = 0.3  # the step at 10 s: out for 1.5 s
    e_z[(t >= 20) & (t < 30)] = 0.2  # the step at 20 s: never back
    pos = np.zeros((len(t), 3))
    pos[:, 2] = e_z
    data = RunData("x", "smarc", t, pos, np.zeros_like(pos), np.zeros_like(pos), np.ones_like(t),
                   np.zeros_like(pos), np.array([]), np.zeros((0, 3)), np.array([]), {}, {})
    rec = recovery_times(data, [10.0, 20.0])
    assert abs(rec[0] - 1.5) < 0.011 and rec[1] is None


def synthetic_run(controller: str = "smarc") -> RunData:
    """A 30 s mission sampled at 100 Hz, mass 1 -> 3 kg at 10 s, with board estimates every 20 ms whose errors are
    set by hand: m̂ = m − 0.1 kg over the last 2 s of each window (m elsewhere), d̂ = d_s + (0.3, −0.4, 0),
    u1 = 10 + sin t."""
    t = np.arange(0.0, 30.0, 0.01)
    mass = np.where(t < 10, 1.0, 3.0)
    force = np.column_stack((np.sin(np.pi * t), np.cos(np.pi * t), -np.cos(np.pi * t)))
    est_t = t[::2]
    est_mass = np.where(est_t < 10, 1.0, 3.0)
    last_2s = ((est_t >= 8) & (est_t < 10)) | (est_t >= 28)
    d_hat = force[::2] + np.array((0.3, -0.4, 0.0))
    estimates = {"m_hat": est_mass - 0.1 * last_2s, "thrust_n": 10 + np.sin(est_t), "d_hat_x": d_hat[:, 0],
                 "d_hat_y": d_hat[:, 1], "d_hat_z": d_hat[:, 2]}
    zeros = np.zeros((len(t), 3))
    return RunData("x", controller, t, zeros, zeros, zeros, mass, force, est_t, np.zeros((len(est_t), 3)), est_t,
                   estimates, {"settle_s": 2.0})


def test_the_estimate_columns_give_the_errors_put_into_a_synthetic_run():
    data = synthetic_run()
    rows = _estimate_rows(data, 2.0, _windows(data, [10.0], 0.0))
    assert rows["mass_estimate_mean_last_2s_pct"] == [approx(-10.0), approx(-100 * 0.1 / 3)]
    assert rows["disturbance_estimate_rms_n"] == [approx(0.3), approx(0.4), approx(0.0, abs=1e-12)]
    assert rows["thrust_n"]["min"] == approx(9.0, abs=1e-3) and rows["thrust_n"]["max"] == approx(11.0, abs=1e-3)


def test_paper_frame_figures_carry_each_controllers_figure_numbers_and_the_papers_angle_signs():
    assert [_name(synthetic_run(c), PAPER_FRAME, "attitude") for c in ("smarc", "smpid", "backstepping")] == [
        "fig7_attitude.png", "fig14_attitude.png", "fig18_attitude.png"]
    assert _name(synthetic_run("smpid"), PAPER_FRAME, "thrust") == "thrust.png"  # the paper draws u1 for SMARC only
    data = synthetic_run()
    data.rpy[:] = (0.02, -0.01, 0.5)  # flown; commanded zero roll and pitch, yaw 0.5 rad
    data.cmd_rpy[:] = (0.0, 0.0, 0.5)
    error = attitude_error(data, PAPER_FRAME)
    assert error[0] == approx(np.degrees((-0.02, 0.01, 0.0)))  # γ = −roll, θ = −pitch, ψ = yaw


def short_scenario(tmp_path: Path) -> Path:
    path = tmp_path / "cmp.yaml"
    path.write_text("name: cmp\nduration_s: 6\nseed: 1\nreference: {type: hover, altitude_m: 3}\nend: disarm\n"
                    "payload: [{t_s: 3, mass_kg: 0.3}]\ndisturbance: {force_ned: ['0.3*sin(t)', 0, 0]}\n"
                    "expect: {settle_s: 1}\n")
    return path


def test_report_draws_the_papers_figures_for_a_run(tmp_path):
    runs = tmp_path / "runs"
    subprocess.run([sys.executable, "-m", "hil", "run", str(short_scenario(tmp_path)), "--runs", str(runs),
                    "--no-telemetry"], check=True, capture_output=True, cwd=ROOT, timeout=300)
    run_dir = next(runs.iterdir())
    result = subprocess.run([sys.executable, "-m", "hil", "report", str(run_dir)], capture_output=True, text=True,
                            cwd=ROOT, timeout=300)
    assert result.returncode == 0, result.stderr
    names = {Path(line).name for line in result.stdout.split() if line.endswith(".png")}
    assert names == {"fig5_trajectory.png", "fig6_position_error.png", "fig7_attitude.png", "fig8_thrust.png",
                     "fig9_mass_estimate.png", "fig10_disturbance_estimate.png"}
    for name in names:
        data = (run_dir / "report" / name).read_bytes()
        assert data.startswith(PNG_MAGIC) and len(data) > 10_000
    paper = subprocess.run([sys.executable, "-m", "hil", "report", str(run_dir), "--paper-frame"],
                           capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert paper.returncode == 0, paper.stderr
    assert {Path(line).name for line in paper.stdout.split() if Path(line).parent.name == "paper_frame"} == names
    bad = subprocess.run([sys.executable, "-m", "hil", "report", str(tmp_path)], capture_output=True, text=True,
                         cwd=ROOT)
    assert bad.returncode == 2 and "not a run directory" in bad.stderr


def test_compare_flies_each_controller_and_tabulates_them(tmp_path):
    out = tmp_path / "cmp"
    result = subprocess.run([sys.executable, "-m", "hil", "compare", str(short_scenario(tmp_path)),
                             "--controllers", "smarc,backstepping", "--jobs", "2", "--out", str(out)],
                            capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert result.returncode == 0, result.stdout + result.stderr
    comparison = json.loads((out / "comparison.json").read_text())
    assert set(comparison["controllers"]) == {"smarc", "backstepping"}
    assert all(r["exit_code"] in (0, 1) for r in comparison["runs"])
    for name, row in comparison["controllers"].items():
        run = next(r for r in comparison["runs"] if r["controller"] == name)
        metrics = json.loads((Path(run["run_dir"]) / "metrics.json").read_text())
        # one seed: the pooled table equals that run's own metrics
        assert abs(row["position_error_m"]["x"]["max_abs"] - metrics["position_error_m"]["x"]["max_abs"]) < 1e-12
        assert len(row["z_recovery_s"]) == 1
    assert "mass_estimate_error_pct" in comparison["controllers"]["smarc"]
    assert "mass_estimate_error_pct" not in comparison["controllers"]["backstepping"]
    markdown = (out / "comparison.md").read_text()
    assert "| smarc |" in markdown and "| backstepping |" in markdown
    assert (out / "overlay_position_error.png").read_bytes().startswith(PNG_MAGIC)
    for run in comparison["runs"]:  # backstepping's internals reach the recording by name: its u1 is drawn too
        assert (Path(run["run_dir"]) / "report" / "fig8_thrust.png").read_bytes().startswith(PNG_MAGIC)
    assert "u1 range" in markdown and "Tables 1–2 are flight data" in markdown
