"""`hil compare`: one scenario flown by several controllers (and seeds) on the emulator, in parallel
processes, summarised like the paper's Tables 1–2, with overlaid plots."""

from __future__ import annotations

import json
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from hil.rundata import RunData, load_run, recovery_times
from hil.scenario.schema import Scenario


@dataclass
class Flight:
    controller: str
    seed: int
    run_dir: Path
    exit_code: int


def _fly(scenario_path: Path, controller: str, seed: int, runs: Path) -> Flight:
    out = runs / f"{controller}-seed{seed}"
    out.mkdir(parents=True, exist_ok=True)
    result = subprocess.run([sys.executable, "-m", "hil.cli", "run", str(scenario_path), "--controller", controller,
                             "--seed", str(seed), "--runs", str(out), "--no-telemetry"], capture_output=True, text=True)
    run_dir = sorted(out.iterdir())[-1] if any(out.iterdir()) else out
    return Flight(controller, seed, run_dir, result.returncode)


def _controller_row(data: list[RunData], scenario: Scenario, settle_s: float) -> dict[str, Any]:
    """Position-error ranges, RMS and max over the seeds (Table 1); attitude ranges (Table 2); m̂; timing."""
    row: dict[str, Any] = {"runs": len(data)}
    errors = np.concatenate([d.error[d.t >= settle_s] for d in data])
    row["position_error_m"] = {axis: {"min": float(errors[:, i].min()), "max": float(errors[:, i].max()),
                                      "rms": float(np.sqrt(np.mean(errors[:, i] ** 2))),
                                      "max_abs": float(np.abs(errors[:, i]).max())} for i, axis in enumerate("xyz")}
    att = [d.metrics.get("attitude_error_deg") for d in data if d.metrics.get("attitude_error_deg")]
    if att:
        row["attitude_error_deg"] = {a: {"min": min(x[a]["min"] for x in att), "max": max(x[a]["max"] for x in att)}
                                     for a in ("roll", "pitch", "yaw")}
    windows = [d.metrics.get("board_estimates", {}).get("mass_estimate_windows") for d in data]
    windows = [w for w in windows if w]
    if windows:
        row["mass_estimate_error_pct"] = [float(np.mean([w[i]["error_pct"] for w in windows]))
                                          for i in range(min(len(w) for w in windows))]
    steps = sorted(p.t_s for p in scenario.payload)
    if steps:
        recoveries = [recovery_times(d, steps) for d in data]
        row["z_recovery_s"] = [None if any(r[i] is None for r in recoveries) else max(r[i] for r in recoveries)
                               for i in range(len(steps))]
    row["realtime_factor"] = float(np.mean([d.metrics["timing"]["realtime_factor"] for d in data]))
    return row


def _markdown(scenario: Scenario, rows: dict[str, dict[str, Any]], settle_s: float, seeds: list[int]) -> str:
    lines = [f"# Comparison: {scenario.name}", "",
             f"Seeds {', '.join(map(str, seeds))}; errors after {settle_s:g} s of the mission (true position − "
             "reference), pooled over the seeds.", "",
             "| controller | e_x range (m) | e_y range (m) | e_z range (m) | RMS x / y / z (m) | max \\|e_z\\| (m) |",
             "| --- | --- | --- | --- | --- | --- |"]
    for name, row in rows.items():
        p = row["position_error_m"]
        lines.append(f"| {name} | [{p['x']['min']:+.3f}, {p['x']['max']:+.3f}] | [{p['y']['min']:+.3f}, "
                     f"{p['y']['max']:+.3f}] | [{p['z']['min']:+.3f}, {p['z']['max']:+.3f}] | {p['x']['rms']:.3f} / "
                     f"{p['y']['rms']:.3f} / {p['z']['rms']:.3f} | {p['z']['max_abs']:.3f} |")
    if any("attitude_error_deg" in r for r in rows.values()):
        lines += ["", "| controller | roll error (deg) | pitch error (deg) | yaw error (deg) |", "| --- | --- | --- | --- |"]
        for name, row in rows.items():
            a = row.get("attitude_error_deg")
            if a:
                lines.append(f"| {name} | " + " | ".join(f"[{a[k]['min']:+.2f}, {a[k]['max']:+.2f}]"
                                                       for k in ("roll", "pitch", "yaw")) + " |")
    lines += ["", "z recovery: seconds after a mass step until \\|e_z\\| is back for good inside max(0.05 m, 3 × its "
              "RMS over the 2 s before the first step).", "",
              "| controller | m̂ error at the end of each payload window (%) | z recovery after each mass step (s) |"
              " real-time factor |", "| --- | --- | --- | --- |"]
    for name, row in rows.items():
        mass = ", ".join(f"{e:+.1f}" for e in row.get("mass_estimate_error_pct", [])) or "– (no estimate)"
        rec = ", ".join("never" if r is None else f"{r:.2f}" for r in row.get("z_recovery_s", [])) or "–"
        lines.append(f"| {name} | {mass} | {rec} | {row['realtime_factor']:.2f} |")
    return "\n".join(lines) + "\n"


def compare(scenario_path: Path, scenario: Scenario, controllers: list[str], seeds: list[int], jobs: int,
            out: Path) -> tuple[dict[str, Any], str]:
    out.mkdir(parents=True, exist_ok=True)
    runs = out / "runs"
    plan = [(c, s) for c in controllers for s in seeds]
    with ThreadPoolExecutor(max_workers=max(jobs, 1)) as pool:  # each flight is its own process pair
        flights = list(pool.map(lambda cs: _fly(scenario_path, cs[0], cs[1], runs), plan))
    failed = [f for f in flights if f.exit_code not in (0, 1)]
    settle_s = scenario.expect.settle_s if scenario.expect else 2.0
    data: dict[str, list[RunData]] = {c: [load_run(f.run_dir) for f in flights if f.controller == c and f not in failed]
                                      for c in controllers}
    rows = {c: _controller_row(d, scenario, settle_s) for c, d in data.items() if d}
    result = {"scenario": scenario.name, "seeds": seeds, "settle_s": settle_s, "controllers": rows,
              "runs": [{"controller": f.controller, "seed": f.seed, "run_dir": str(f.run_dir), "exit_code": f.exit_code}
                       for f in flights]}
    markdown = _markdown(scenario, rows, settle_s, seeds)
    if failed:
        markdown += "\nRuns that did not complete: " + ", ".join(f"{f.controller} seed {f.seed} (exit {f.exit_code})"
                                                                for f in failed) + "\n"
    (out / "comparison.json").write_text(json.dumps(result, indent=2))
    (out / "comparison.md").write_text(markdown)
    from hil.report import overlay_errors, report  # plotting stays out of the loop: imported only here

    for flight in flights:
        if flight not in failed:
            report(flight.run_dir)
    first_seed = {c: d[0] for c, d in data.items() if d}
    if first_seed:
        overlay_errors(first_seed, out, settle_s)
    return result, markdown
