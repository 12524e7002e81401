"""Regenerates the figures and tables of docs/aerodynamics.md: gust.yaml (rotor aerodynamics on) and
gust_aero_compare.yaml (off), same seed, SMARC on the emulator through the whole chain; then the same
pair with ideal sensors and the true state given to the controller, which isolates the dynamics.

Usage: python docs/aerodynamics/make_figures.py   (writes docs/aerodynamics/*.png, prints the table)
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
from hil.reports.png import overlay_errors  # noqa: E402
from hil.reports.rundata import load_run  # noqa: E402

OUT = Path(__file__).resolve().parent
RUNS = {"rotor aerodynamics on (gust.yaml)": "gust", "off (gust_aero_compare.yaml)": "gust_aero_compare"}
SETTLE_S = 5.0


IDEAL = {"sensors": {s: {"profile": "ideal"} for s in ("imu", "mag", "baro", "gps")}}


def fly(name: str, runs: Path, ideal: bool) -> Path:
    scenario = yaml.safe_load((ROOT / "scenarios" / f"{name}.yaml").read_text())
    if ideal:
        scenario.update(IDEAL)
        scenario["board"] = {**scenario.get("board", {}), "state_source": "truth"}
        scenario.pop("expect", None)
    path = runs / f"{name}.yaml"
    path.write_text(yaml.safe_dump(scenario))
    subprocess.run([sys.executable, "-m", "hil", "run", str(path), "--runs", str(runs / name), "--no-telemetry"],
                   check=True, cwd=ROOT, stdout=subprocess.DEVNULL)
    return next(p for p in (runs / name).iterdir() if p.is_dir())


def main() -> None:
    for ideal, suffix in ((False, ""), (True, "_ideal_sensors")):
        with tempfile.TemporaryDirectory() as tmp:
            data = {label: load_run(fly(name, Path(tmp), ideal)) for label, name in RUNS.items()}
        plot_and_tabulate(data, suffix, "ideal sensors, true state" if ideal else "px4_sitl sensors, estimator")


def plot_and_tabulate(data: dict, suffix: str, what: str) -> None:
    overlay_errors(data, OUT, SETTLE_S, f"SMARC, gust.yaml, {what}: with and without rotor aerodynamics "
                   "(gusts shaded)", f"gust_error_with_and_without{suffix}.png", ((15, 17), (35, 38)))
    print(f"\n{what}\n")
    print("| run | axis | RMS (m) | max abs (m) | max abs in gust 1 (15-20 s) | in gust 2 (35-41 s) |")
    print("|---|---|---|---|---|---|")
    for label, run in data.items():
        settled = run.t >= SETTLE_S
        for i, axis in enumerate("xyz"):
            e = run.error[settled, i]
            gust1 = np.abs(run.error[(run.t >= 15) & (run.t < 20), i]).max()
            gust2 = np.abs(run.error[(run.t >= 35) & (run.t < 41), i]).max()
            print(f"| {label} | {axis} | {np.sqrt(np.mean(e**2)):.3f} | {np.abs(e).max():.3f} | {gust1:.3f} | "
                  f"{gust2:.3f} |")


if __name__ == "__main__":
    main()
