"""`hil report` and `hil compare` on real (short) runs, and the z-recovery measure on a hand-made trace."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np

from hil.rundata import RunData, recovery_times

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


def short_scenario(tmp_path: Path) -> Path:
    path = tmp_path / "cmp.yaml"
    path.write_text("name: cmp\nduration_s: 6\nseed: 1\nreference: {type: hover, altitude_m: 3}\nend: disarm\n"
                    "payload: [{t_s: 3, mass_kg: 0.3}]\ndisturbance: {force_ned: ['0.3*sin(t)', 0, 0]}\n"
                    "expect: {settle_s: 1}\n")
    return path


def test_report_draws_the_papers_figures_for_a_run(tmp_path):
    runs = tmp_path / "runs"
    subprocess.run([sys.executable, "-m", "hil.cli", "run", str(short_scenario(tmp_path)), "--runs", str(runs),
                    "--no-telemetry"], check=True, capture_output=True, cwd=ROOT, timeout=300)
    run_dir = next(runs.iterdir())
    result = subprocess.run([sys.executable, "-m", "hil.cli", "report", str(run_dir)], capture_output=True, text=True,
                            cwd=ROOT, timeout=300)
    assert result.returncode == 0, result.stderr
    names = {Path(line).name for line in result.stdout.split()}
    assert names == {"fig5_trajectory.png", "fig6_position_error.png", "fig7_attitude.png", "fig8_thrust.png",
                     "fig9_mass_estimate.png", "fig10_disturbance_estimate.png"}
    for name in names:
        data = (run_dir / "report" / name).read_bytes()
        assert data.startswith(PNG_MAGIC) and len(data) > 10_000
    bad = subprocess.run([sys.executable, "-m", "hil.cli", "report", str(tmp_path)], capture_output=True, text=True,
                         cwd=ROOT)
    assert bad.returncode == 2 and "not a run directory" in bad.stderr


def test_compare_flies_each_controller_and_tabulates_them(tmp_path):
    out = tmp_path / "cmp"
    result = subprocess.run([sys.executable, "-m", "hil.cli", "compare", str(short_scenario(tmp_path)),
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
