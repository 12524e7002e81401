"""The summary a run prints and writes to summary.txt: what flew, how the run ended, the errors per axis, timing,
the link, the expectations."""

from __future__ import annotations

import io
import textwrap
from typing import Any

from hil.exit_codes import verdict
from hil.judge.metrics import slip_note
from hil.judge.verdict import Verdict
from hil.scenario.schema import Scenario

SUMMARY_WIDTH = 100  # columns: the summary fits a terminal and the file reads the same


def _error_table(metrics: dict[str, Any]) -> str:
    """The per-axis error figures as a table: [min, max], RMS and max |e| per axis and quantity."""
    from rich.console import Console
    from rich.table import Table

    rows = [("position - reference (m)", "position_error_m", 3),
            ("board estimate - truth (m)", "board_estimate_error_m", 3),
            ("board attitude - truth (deg)", "board_attitude_estimate_error_deg", 2),
            ("attitude - commanded (deg)", "attitude_error_deg", 2)]
    present = [(label, metrics[key], digits) for label, key, digits in rows if metrics.get(key)]
    if not present:
        return ""
    table = Table(box=None, pad_edge=False, show_edge=False, title_justify="left",
                  title=f"mission errors (tracking after {metrics.get('settle_s', 0):g} s): \\[min, max] rms")
    table.add_column("", no_wrap=True)
    for axis in ("x / roll", "y / pitch", "z / yaw"):
        table.add_column(axis, justify="right", overflow="fold")
    for label, stats, digits in present:
        cells = [f"[{s['min']:+.{digits}f}, {s['max']:+.{digits}f}] {s['rms']:.{digits}f}" if s else "–"
                 for s in stats.values()]
        table.add_row(label, *cells)
    console = Console(width=SUMMARY_WIDTH, file=io.StringIO(), color_system=None, force_terminal=False)
    console.print(table)
    text = console.file.getvalue()  # type: ignore[attr-defined]
    return "\n".join(line.rstrip() for line in text.splitlines())


def _expectation_lines(metrics: dict[str, Any], failures: list[str]) -> list[str]:
    """Met or not, each expectation not met (-), and each behaviour expectation met (+) with when it was decided."""
    return ["expectations: " + ("met" if not failures else "NOT met"), *(f"  - {f}" for f in failures),
            *(f"  + {Verdict(**v).line()}" for v in metrics.get("verdicts", []) if v["met"])]


def format_summary(scenario: Scenario, board: str, flight_code: str, reason: str, code: int,
                   metrics: dict[str, Any], failures: list[str]) -> str:
    result = verdict(code)
    lines = [f"scenario: {scenario.name} (seed {scenario.seed}, {scenario.rate_hz:g} Hz, {scenario.duration_s:g} s)",
             f"board: {board}", f"flight code: {flight_code}",
             f"result: {result} (exit {code})", f"ended: {reason}"]
    if "phase_reached" in metrics:
        lines.append(f"phase reached: {metrics['phase_reached']}")
    table = _error_table(metrics)
    if table:
        lines += table.rstrip("\n").splitlines()
    for window in metrics.get("board_estimates", {}).get("mass_estimate_windows", []):
        lines.append(f"mass estimate at {window['end_s']:.1f} s: {window['m_hat_kg']:.3f} kg "
                     f"(true {window['true_mass_kg']:.2f} kg, {window['error_pct']:+.1f} %)")
    timing = metrics.get("timing")
    if timing:
        rtf = timing.get("realtime_factor")
        lines.append(f"timing: {timing['sim_s']:.2f} s simulated in {timing['wall_s']:.2f} s wall"
                     + (f", real-time factor {rtf:.2f}" if rtf else ""))
        if timing.get("round_trip_us"):
            rt = timing["round_trip_us"]
            lines.append(f"sensor -> actuator round trip: p50 {rt['p50']:.0f} us, p99 {rt['p99']:.0f} us")
        lines += _dropped_replies(timing)
        if timing.get("board_cpu_us_per_step") is not None:
            lines.append(f"board's own CPU: {timing['board_cpu_us_per_step']:.0f} us per step")
        if timing.get("idle_cpus"):
            lines.append(f"idle CPUs: {timing['idle_cpus']}")
        if "period_jitter_us" in timing:
            j = timing["period_jitter_us"]
            lines.append(f"step period jitter: p50 {j['p50']:.0f} us, p99 {j['p99']:.0f} us, max {j['max']:.0f} us, "
                         f"late steps {timing['late_steps']}{slip_note(timing)}")
    link = metrics.get("link")
    if link:
        errors = {k: v for k, v in link.items()
                  if k not in ("frames_in", "frames_out", "bytes_in", "bytes_out", "passed_through") and v}
        lines.append(f"link: {link.get('frames_in', 0)} frames in, {link.get('frames_out', 0)} out; "
                     f"errors: {errors or 'none'}")
    if scenario.expect is not None and reason == "completed":  # checked only for a flight that completed
        lines += _expectation_lines(metrics, failures)
    return "\n".join(textwrap.fill(line, SUMMARY_WIDTH, subsequent_indent="    ", break_on_hyphens=False)
                     if len(line) > SUMMARY_WIDTH else line for line in lines) + "\n"


def _dropped_replies(timing: dict[str, Any]) -> list[str]:
    """The line on the lockstep replies the board dropped (`board_dropped_reply`), where it dropped any."""
    dropped = timing.get("lockstep_replies_dropped")
    if not dropped:
        return []
    at = ", ".join(f"{t:.3f}" for t in dropped["at_s"][:5]) + (", ..." if dropped["count"] > 5 else "")
    return [f"lockstep replies the board dropped: {dropped['count']} (steps at {at} s), each stepped past with its "
            "last outputs"]
