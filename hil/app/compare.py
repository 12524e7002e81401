"""`hil compare`: one scenario flown by several controllers (and seeds) on the emulator, summarised in tables of
the simulation's tracking, attitude and estimate figures (the paper's Tables 1–2 are flight data, not these),
with overlaid plots. The flights are a grid sweep (controllers × seeds) run by `hil.sweep`, the one code path
for parallel runs."""

from __future__ import annotations

import json
from dataclasses import dataclass
from itertools import pairwise
from pathlib import Path
from typing import Any

import numpy as np

from hil.reports.rundata import RunData, load_run, recovery_times
from hil.scenario.schema import Scenario
from hil.sweep import run_spec
from hil.sweep.results import flight_metrics
from hil.sweep.spec import SweepSpec


@dataclass
class Flight:
    controller: str
    seed: int
    run_dir: Path
    exit_code: int


def _fly_all(scenario_path: Path, scenario: Scenario, controllers: list[str], seeds: list[int], jobs: int,
             out: Path) -> tuple[list[Flight], list[str]]:
    """The flights, and a note per controller whose seeds all gave the same flight (a deterministic study:
    ideal sensors and no turbulence leave the seed nothing to change)."""
    spec = SweepSpec(name=f"compare-{scenario.name}", scenario=scenario_path.resolve(), design="grid",
                     cross={"board.controller": controllers, "seed": seeds})
    outcome = run_spec(spec, out, jobs=jobs)
    if outcome.interrupted:
        raise KeyboardInterrupt
    flights = [Flight(r["board.controller"], r["seed"], Path(r["run_dir"]), r["exit_code"]) for r in outcome.rows]
    notes = []
    for controller in controllers:
        rows = [r for r in outcome.rows if r["board.controller"] == controller and r["exit_code"] in (0, 1)]
        same = [flight_metrics(r, outcome.varied) for r in rows]
        if len(same) > 1 and all(m == same[0] for m in same):
            notes.append(f"{controller}: seeds {', '.join(str(r['seed']) for r in rows)} gave identical metrics; "
                         "this study is deterministic (ideal sensors, no turbulence), so more seeds change nothing.")
    return flights, notes


def _windows(data: RunData, steps: list[float], start_s: float) -> list[tuple[float, float]]:
    """The payload windows of the mission that the flight reached: from `start_s` to the first step, between
    steps, to the end."""
    end = float(data.t[-1]) + 1e-9
    bounds = [start_s, *(t for t in steps if t < end), end]
    return [(a, b) for a, b in pairwise(bounds) if a < b]


def _estimate_rows(data: RunData, settle_s: float, windows: list[tuple[float, float]]) -> dict[str, Any]:
    """u1 range, m̂ at the end of and averaged over the last 2 s of each window, RMS of d̂ − d_s: what the
    paper's Figures 8–10 show, as numbers."""
    out: dict[str, Any] = {}
    est, after = data.estimates, data.est_t >= settle_s
    if "thrust_n" in est and after.any():
        u1 = est["thrust_n"][after]
        out["thrust_n"] = {"min": float(np.nanmin(u1)), "max": float(np.nanmax(u1))}
    if "m_hat" in est:
        true_mass = np.interp(data.est_t, data.t, data.mass)
        means = []
        for start, end in windows:
            last = (data.est_t >= max(start, end - 2.0)) & (data.est_t < end)
            if last.any():
                means.append(float(100 * np.mean(est["m_hat"][last] / true_mass[last] - 1)))
        out["mass_estimate_mean_last_2s_pct"] = means
    d_keys = ("d_hat_x", "d_hat_y", "d_hat_z")
    if all(k in est for k in d_keys) and after.any():
        applied = np.column_stack([np.interp(data.est_t, data.t, data.force[:, i]) for i in range(3)])
        miss = np.column_stack([est[k] for k in d_keys]) - applied
        out["disturbance_estimate_rms_n"] = [float(np.sqrt(np.mean(miss[after, i] ** 2))) for i in range(3)]
    return out


def _slowest(recoveries: list[float | None]) -> float | None:
    """The slowest recovery over the seeds; None when any seed never recovered."""
    times = [r for r in recoveries if r is not None]
    return max(times) if len(times) == len(recoveries) else None


def _error_rows(data: list[RunData], steps: list[float], settle_s: float) -> dict[str, Any]:
    """Position-error range, RMS and max |e| per axis over the seeds, and e_z's range per payload window."""
    errors = np.concatenate([d.error[d.t >= settle_s] for d in data])
    by_window = []
    for start, end in _windows(max(data, key=lambda d: d.t[-1]), steps, settle_s):
        e_z = np.concatenate([d.error[(d.t >= start) & (d.t < end), 2] for d in data])
        by_window.append({"start_s": start, "end_s": end, "min": float(e_z.min()), "max": float(e_z.max())})
    return {"position_error_m": {axis: {"min": float(errors[:, i].min()), "max": float(errors[:, i].max()),
                                        "rms": float(np.sqrt(np.mean(errors[:, i] ** 2))),
                                        "max_abs": float(np.abs(errors[:, i]).max())}
                                 for i, axis in enumerate("xyz")},
            "z_error_by_window_m": by_window}


def _controller_row(data: list[RunData], scenario: Scenario, settle_s: float) -> dict[str, Any]:
    """Position-error ranges, RMS and max over the seeds, e_z per payload window; attitude ranges; u1, m̂ and d̂
    (the first seed's); timing. The simulation's figures, which the paper shows as Figures 5–18 only (its
    Tables 1–2 are flight data)."""
    row: dict[str, Any] = {"runs": len(data)}
    steps = sorted(p.t_s for p in scenario.payload)
    row.update(_error_rows(data, steps, settle_s))
    att = [a for d in data if (a := d.metrics.get("attitude_error_deg"))]
    if att:
        row["attitude_error_deg"] = {a: {"min": min(x[a]["min"] for x in att), "max": max(x[a]["max"] for x in att)}
                                     for a in ("roll", "pitch", "yaw")}
    mass_windows = [d.metrics.get("board_estimates", {}).get("mass_estimate_windows") for d in data]
    mass_windows = [w for w in mass_windows if w]
    if mass_windows:
        row["mass_estimate_error_pct"] = [float(np.mean([w[i]["error_pct"] for w in mass_windows]))
                                          for i in range(min(len(w) for w in mass_windows))]
    row.update(_estimate_rows(data[0], settle_s, _windows(data[0], steps, 0.0)))
    if steps:
        recoveries = [recovery_times(d, steps) for d in data]
        row["z_recovery_s"] = [_slowest([r[i] for r in recoveries]) for i in range(len(steps))]
    row["realtime_factor"] = float(np.mean([d.metrics["timing"]["realtime_factor"] for d in data]))
    return row


def _range(low: float, high: float, digits: int) -> str:
    return f"[{low:+.{digits}f}, {high:+.{digits}f}]"


def _markdown(scenario: Scenario, rows: dict[str, dict[str, Any]], settle_s: float, seeds: list[int]) -> str:
    lines = [f"# Comparison: {scenario.name} (simulation through the HIL chain)", "",
             f"Seeds {', '.join(map(str, seeds))}; errors after {settle_s:g} s of the mission (true position − "
             "reference, NED), pooled over the seeds. The paper shows its simulation as figures only; its Tables 1–2 "
             "are flight data (§6).", "",
             "| controller | e_x range (m) | e_y range (m) | e_z range (m) | RMS x / y / z (m) | max \\|e_z\\| (m) |",
             "| --- | --- | --- | --- | --- | --- |"]
    for name, row in rows.items():
        p = row["position_error_m"]
        lines.append(f"| {name} | {_range(p['x']['min'], p['x']['max'], 3)} | {_range(p['y']['min'], p['y']['max'], 3)}"
                     f" | {_range(p['z']['min'], p['z']['max'], 3)} | {p['x']['rms']:.3f} / {p['y']['rms']:.3f} / "
                     f"{p['z']['rms']:.3f} | {p['z']['max_abs']:.3f} |")
    if any("attitude_error_deg" in r for r in rows.values()):
        lines += ["", "| controller | roll error (deg) | pitch error (deg) | yaw error (deg) |",
                  "| --- | --- | --- | --- |"]
        for name, row in rows.items():
            a = row.get("attitude_error_deg")
            if a:
                lines.append(f"| {name} | " + " | ".join(_range(a[k]["min"], a[k]["max"], 2)
                                                       for k in ("roll", "pitch", "yaw")) + " |")
    lines += ["", "Per payload window (the first from the settle time): e_z range; m̂ − m at the window's end and "
              "averaged over its last 2 s; u1 range after the settle time; RMS of d̂_s − d_s (N, x / y / z). "
              "z recovery: seconds after a mass step until \\|e_z\\| is back for good inside max(0.05 m, 3 × its "
              "RMS over the 2 s before the first step).", "",
              "| controller | e_z per window (m) | m̂ error at the end / mean of the last 2 s (%) | u1 range (N) | "
              "RMS d̂_s − d_s (N) | z recovery after each mass step (s) | real-time factor |",
              "| --- | --- | --- | --- | --- | --- | --- |"]
    for name, row in rows.items():
        windows = "; ".join(_range(w["min"], w["max"], 3) for w in row["z_error_by_window_m"])
        ends, means = row.get("mass_estimate_error_pct", []), row.get("mass_estimate_mean_last_2s_pct", [])
        mass = "; ".join(f"{e:+.1f} / {m:+.1f}" for e, m in zip(ends, means, strict=False)) or "– (no estimate)"
        u1 = row.get("thrust_n")
        d = row.get("disturbance_estimate_rms_n")
        rec = ", ".join("never" if r is None else f"{r:.2f}" for r in row.get("z_recovery_s", [])) or "–"
        lines.append(f"| {name} | {windows} | {mass} | {_range(u1['min'], u1['max'], 1) if u1 else '–'} | "
                     f"{' / '.join(f'{v:.2f}' for v in d) if d else '–'} | {rec} | {row['realtime_factor']:.2f} |")
    return "\n".join(lines) + "\n"


def compare(scenario_path: Path, scenario: Scenario, controllers: list[str], seeds: list[int], jobs: int,
            out: Path) -> tuple[dict[str, Any], str]:
    flights, notes = _fly_all(scenario_path, scenario, controllers, seeds, jobs, out)
    failed = [f for f in flights if f.exit_code not in (0, 1)]
    settle_s = scenario.expect.settle_s if scenario.expect else 2.0
    data: dict[str, list[RunData]] = {c: [load_run(f.run_dir) for f in flights if f.controller == c and f not in failed]
                                      for c in controllers}
    rows = {c: _controller_row(d, scenario, settle_s) for c, d in data.items() if d}
    result = {"scenario": scenario.name, "seeds": seeds, "settle_s": settle_s, "controllers": rows,
              "runs": [{"controller": f.controller, "seed": f.seed, "run_dir": str(f.run_dir), "exit_code": f.exit_code}
                       for f in flights]}
    markdown = _markdown(scenario, rows, settle_s, seeds) + "".join(f"\n{n}\n" for n in notes)
    if failed:
        markdown += "\nRuns that did not complete: " + ", ".join(f"{f.controller} seed {f.seed} (exit {f.exit_code})"
                                                                for f in failed) + "\n"
    (out / "comparison.json").write_text(json.dumps(result, indent=2))
    (out / "comparison.md").write_text(markdown)
    from hil.reports.png import (  # plotting stays out of the loop: imported only here
        overlay_errors,
        report,
    )

    for flight in flights:
        if flight not in failed:
            report(flight.run_dir)
    first_seed = {c: d[0] for c, d in data.items() if d}
    if first_seed:
        overlay_errors(first_seed, out, settle_s)
    return result, markdown
