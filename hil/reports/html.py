"""One self-contained HTML page per run, `RUN_DIR/report.html`: the verdict on each `expect` line, how the run
ended, the scenario at a glance, metrics, the figures (PNG inside the page as data: URIs) and the events.

Nothing on the page is fetched: no script, no stylesheet, font or image from elsewhere, so the page opens the
same from a CI artifact, a mail attachment or a machine without a network.
"""

from __future__ import annotations

import base64
import html
import math
import os
import re
import struct
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from matplotlib.colors import to_hex

from hil.exit_codes import verdict
from hil.judge.metrics import slip_note
from hil.reports.figures import render
from hil.reports.plotting import PAYLOAD_COLOUR, SPAN_STYLE, Bounds
from hil.reports.rundata import Flight, NoFlightData, load_flight

__all__ = ["NoFlightData", "write_report"]

_NUMBER = re.compile(r"[+-]?\d[\d.]*(\s?\S{1,3})?")
STYLE = """
body{font-family:"DejaVu Sans",Helvetica,Arial,sans-serif;max-width:1320px;margin:0 auto;padding:12px 16px;
color:#1d1d1d;background:#fff;font-size:14px}
h1{font-size:22px;margin:8px 0}h2{font-size:18px;margin:22px 0 6px;border-bottom:1px solid #ddd}
table{border-collapse:collapse;margin:6px 0 10px}th,td{border:1px solid #ccc;padding:3px 8px;text-align:left;
vertical-align:top}th{background:#f3f3f3}td.num{text-align:right;font-variant-numeric:tabular-nums}
.PASS{background:#d9f2d9;color:#0b5d1e;font-weight:bold}.FAIL{background:#f9d6d5;color:#8a1111;font-weight:bold}
.ABORTED,.unchecked{background:#fbe7c6;color:#7a4a00;font-weight:bold}
figure{margin:14px 0 22px}figure img{display:block;max-width:100%;height:auto;border:1px solid #e3e3e3}
figcaption{color:#444;margin-top:4px}pre{background:#f7f7f7;padding:8px;overflow-x:auto;font-size:12px}
.key span{display:inline-block;width:26px;height:12px;margin:0 4px 0 14px;vertical-align:middle}
nav a{margin-right:12px}
"""


@dataclass
class Check:
    """One expect line: what was measured against its bound."""

    name: str
    measured: str
    bound: str
    passed: bool


def _is_px4(flight: Flight) -> bool:
    """The runner applies the scenario's `expect.px4` bounds to every board but the built-in emulator."""
    return flight.meta.get("board", "emulator") != "emulator"


def bounds_of(flight: Flight) -> Bounds:
    expect = dict(flight.scenario.get("expect") or {})
    px4 = expect.pop("px4", None) or {}
    if _is_px4(flight):
        expect.update({k: v for k, v in px4.items() if v is not None})
    error = expect.get("max_error_m")
    return Bounds(settle_s=float(expect.get("settle_s", 5.0)), mission_end_s=float(flight.scenario["duration_s"]),
                  max_error_m=None if error is None else tuple(error) if isinstance(error, list) else (error,) * 3,
                  max_attitude_error_deg=expect.get("max_attitude_error_deg"),
                  min_realtime_factor=expect.get("min_realtime_factor"))


def checks(bounds: Bounds, metrics: dict[str, Any]) -> list[Check]:
    """Each expect line with the figure from metrics.json it is judged on (as hil.judge.metrics.check_expectations
    judges it: a figure that was not measured fails)."""
    out = []
    if bounds.max_error_m is not None:
        position = metrics.get("position_error_m") or {}
        for axis, name, limit in zip("xyz", ("north", "east", "down"), bounds.max_error_m, strict=True):
            found = position.get(axis, {}).get("max_abs")
            out.append(Check(f"max |e_{axis}| ({name}) after {bounds.settle_s:g} s", _measured(found, " m"),
                             f"≤ {limit:g} m", found is not None and found <= limit))
    if bounds.max_attitude_error_deg is not None:
        attitude = metrics.get("attitude_error_deg") or {}
        found = max(attitude["roll"]["max_abs"], attitude["pitch"]["max_abs"]) if attitude else None
        out.append(Check(f"max roll/pitch error against the commanded attitude after {bounds.settle_s:g} s",
                         _measured(found, "°"), f"≤ {bounds.max_attitude_error_deg:g}°",
                         found is not None and found <= bounds.max_attitude_error_deg))
    if bounds.min_realtime_factor is not None:
        found = (metrics.get("timing") or {}).get("realtime_factor")
        out.append(Check("real-time factor", _measured(found, ""), f"≥ {bounds.min_realtime_factor:g}",
                         found is not None and found >= bounds.min_realtime_factor))
    return out + [_behaviour_check(verdict) for verdict in metrics.get("verdicts", [])]


def _behaviour_check(verdict: dict[str, Any]) -> Check:
    """A behaviour expectation as the judge decided it (hil.judge.behaviour), with the time it was decided."""
    when = verdict["decided_mission_t"]
    at = (f"mission time {when:.2f} s" if when is not None else f"bench time {verdict['decided_t_us'] * 1e-6:.2f} s")
    return Check(f"{verdict['expectation']} (decided at {at})", verdict["found"], verdict["bound"], verdict["met"])


def _measured(value: float | None, unit: str) -> str:
    return "not measured" if value is None else f"{value:.3f}{unit}"


def _badge(result: str) -> str:
    return f'<span class="{result}">{result}</span>'


def _summary_lines(summary: str) -> dict[str, str]:
    """summary.txt's `key: value` lines (result, ended, board, flight code, ...)."""
    return {k.strip(): v.strip() for k, _, v in (line.partition(":") for line in summary.splitlines()) if v}


def _table(rows: list[list[str]], header: list[str] | None = None, raw_columns: tuple[int, ...] = ()) -> str:
    """An HTML table; cells are escaped except in raw_columns (already HTML)."""
    def cell(i: int, value: str) -> str:
        text = value if i in raw_columns else html.escape(value)
        return f"<td{' class=num' if _numeric(value) else ''}>{text}</td>"
    head = "<tr>" + "".join(f"<th>{html.escape(h)}</th>" for h in header) + "</tr>" if header else ""
    body = "".join("<tr>" + "".join(cell(i, v) for i, v in enumerate(row)) + "</tr>" for row in rows)
    return f"<table>{head}{body}</table>"


def _numeric(value: str) -> bool:
    """A number, with at most a unit after it: right-aligned in its column."""
    return _NUMBER.fullmatch(value) is not None


def result_section(flight: Flight, bounds: Bounds) -> str:
    """The verdict, how the run ended, and each expectation with its bound."""
    summary = _summary_lines(flight.summary)
    code = flight.metrics.get("exit_code")
    ended = flight.metrics.get("reason") or summary.get("ended", "not recorded (the run did not finish)")
    rows = [["result", _badge(verdict(code))],
            ["exit code", "not recorded" if code is None else str(code)],
            ["ended", html.escape(ended)],
            ["phase reached", html.escape(str(flight.metrics.get("phase_reached", "not recorded")))]]
    parts = ["<h2 id=result>Result</h2>", _table(rows, raw_columns=(1,))]
    found = checks(bounds, flight.metrics)
    checked = code == 0 or (code == 1 and bool(flight.metrics.get("expectations_failed")))
    if not found:
        parts.append("<p>The scenario states no expectations.</p>")
        return "".join(parts)
    if not checked:
        parts.append("<p class=unchecked>The runner did not judge the expectations: the run ended before it "
                     "could (above). The verdicts below are on the figures the run did record.</p>")
    rows = [[c.name, c.measured, c.bound, _badge("PASS" if c.passed else "FAIL")] for c in found]
    parts.append(_table(rows, ["expect", "measured", "bound", "verdict"], raw_columns=(3,)))
    return "".join(parts)


def _vec(values: list[Any]) -> str:
    return "(" + ", ".join(f"{v:g}" if isinstance(v, (int, float)) else str(v) for v in values) + ")"


def _items(mapping: dict[str, Any], skip: tuple[str, ...] = ()) -> str:
    """`key value` pairs of the set (non-null) fields."""
    return ", ".join(f"{k} {_vec(v) if isinstance(v, list) else f'{v:g}' if isinstance(v, float) else v}"
                     for k, v in mapping.items() if v is not None and k not in skip)


def _wind(wind: dict[str, Any]) -> str:
    parts = [f"steady {_vec(wind.get('steady_ned', [0, 0, 0]))} m/s NED"]
    if wind.get("turbulence"):
        parts.append(f"Dryden turbulence: {_items(wind['turbulence'])}")
    return "; ".join(parts)


def _listing(items: list[dict[str, Any]], describe: Any) -> str:
    return "; ".join(describe(i) for i in items) or "none"


def _flown_row(scenario: dict[str, Any], reference: dict[str, Any]) -> list[str]:
    """What the flight followed: the bench pilot's reference, or who else flew and what mission."""
    pilot = scenario.get("pilot") or {"type": "bench"}
    if pilot["type"] == "bench":
        return ["reference", f"{reference.get('type')}: {_items(reference, ('type',))}"]
    items = pilot.get("items") or []
    mission = f", {len(items)} mission items" + (f" from {Path(pilot['plan']).name}" if pilot.get("plan") else "")
    return ["pilot", f"{pilot['type']}{mission if items else ''}"]


def scenario_rows(flight: Flight) -> list[list[str]]:
    """The resolved scenario at a glance: what flew, on what, through what."""
    s, summary = flight.scenario, _summary_lines(flight.summary)
    vehicle, faults, reference = s.get("vehicle", {}), s.get("faults", {}), s.get("reference", {})
    disturbance = s.get("disturbance", {})
    scripted = any(str(v) not in ("0", "0.0") for v in [*disturbance.get("force_ned", []),
                                                          *disturbance.get("torque_frd", [])])
    sensor_faults = [*s.get("sensors", {}).get("faults", []), *faults.get("sensors", [])]
    overrides = _items(vehicle, ("preset",))
    return [
        ["scenario", f"{s.get('name')} (seed {s.get('seed')})"],
        ["description", " ".join(str(s.get("description", "")).split())],
        ["board", str(flight.meta.get("board", "not recorded"))],
        ["flight code", summary.get("flight code", f"controller {s.get('board', {}).get('controller')}")],
        ["vehicle", f"{vehicle.get('preset')}{' with ' + overrides if overrides else ''}"],
        ["rate, duration", f"{s.get('rate_hz'):g} Hz, mission {s.get('duration_s'):g} s, then {s.get('end')}"],
        _flown_row(s, reference),
        ["wind", _wind(s.get("wind", {}))],
        ["gusts", _listing(s.get("wind", {}).get("gusts", []), lambda g: f"at {g['start_s']:g} s for "
                           f"{g['duration_s']:g} s, peak {_vec(g['peak_ned'])} m/s NED")],
        ["scripted disturbance", f"force NED {_vec(disturbance['force_ned'])} N, torque FRD "
                                 f"{_vec(disturbance['torque_frd'])} N·m" if scripted else "none"],
        ["payload steps", _listing(s.get("payload", []), lambda p: f"{p['mass_kg']:g} kg at {p['t_s']:g} s")],
        ["motor faults", _listing(faults.get("motors", []), lambda m: f"motor {m['motor']} at {m['health']:.0%} "
                                  f"from {m['start_s']:g} s" + ("" if m["end_s"] in (None, math.inf)
                                                               else f" to {m['end_s']:g} s"))],
        ["sensor faults", _listing(sensor_faults, _items)],
        ["link faults", _listing(faults.get("link", []), _items)],
        ["sensors", ", ".join(f"{k} {v.get('profile')}" for k, v in s.get("sensors", {}).items()
                              if isinstance(v, dict))],
    ]


def _stats_rows(metrics: dict[str, Any]) -> list[list[str]]:
    """Per-axis figures of the metrics that have them (Tables 1–2 of the paper, the board's estimate errors)."""
    names = {"position_error_m": "position error (m)", "attitude_error_deg": "attitude error vs commanded (deg)",
             "board_estimate_error_m": "board's position estimate − truth (m)",
             "board_attitude_estimate_error_deg": "board's attitude estimate − truth (deg)"}
    rows = []
    for key, label in names.items():
        for axis, s in (metrics.get(key) or {}).items():
            if s:
                rows.append([label, axis, *(f"{s[k]:+.3f}" for k in ("min", "max")), f"{s['rms']:.3f}",
                             f"{s['max_abs']:.3f}"])
    return rows


def _percentiles(p: dict[str, float] | None) -> str:
    return ", ".join(f"{k} {v:.0f}" for k, v in p.items()) + " µs" if p else "not measured"


def timing_rows(metrics: dict[str, Any]) -> list[list[str]]:
    timing = metrics.get("timing") or {}
    if not timing:
        return []
    rtf = timing.get("realtime_factor")
    rows = [["real-time factor", "not measured" if rtf is None else f"{rtf:.2f} ({timing['sim_s']:.2f} s simulated "
             f"in {timing['wall_s']:.2f} s)"],
            ["step wall time", _percentiles(timing.get("step_wall_us"))],
            ["sensor → actuator round trip", _percentiles(timing.get("round_trip_us"))]]
    if timing.get("board_cpu_us_per_step") is not None:
        rows.append(["the board's own CPU per step", f"{timing['board_cpu_us_per_step']:.0f} µs"])
    if "period_jitter_us" in timing:
        jitter = _percentiles(timing["period_jitter_us"])
        rows.append(["step period jitter", f"{jitter}, late steps {timing.get('late_steps', 0)}{slip_note(timing)}"])
    breakdown = timing.get("breakdown_us_per_step") or {}
    if breakdown:
        rows.append(["per step", ", ".join(f"{k.replace('_', ' ')} {v:.0f}" for k, v in breakdown.items()) + " µs"])
    return rows


def _figure_html(title: str, caption: str, png: bytes) -> str:
    width, height = struct.unpack(">II", png[16:24])  # the PNG's IHDR: the page lays out before decoding
    anchor = title.lower().replace(" ", "-").replace("'", "")
    data = base64.b64encode(png).decode("ascii")
    return (f"<figure id={anchor}><h2>{html.escape(title)}</h2><img alt=\"{html.escape(title)}\" width={width} "
            f"height={height} src=\"data:image/png;base64,{data}\"><figcaption>{html.escape(caption)}</figcaption>"
            "</figure>")


def _marker_key() -> str:
    swatches = [("gust", *SPAN_STYLE["gusts"]), ("motor fault", *SPAN_STYLE["motor_faults"]),
                ("sensor fault", *SPAN_STYLE["sensor_faults"]), ("link fault", *SPAN_STYLE["link_faults"])]
    spans = "".join(f'<span style="background:{to_hex(c)};opacity:{max(a * 2.5, 0.35):.2f}"></span>{name}'
                    for name, c, a in swatches)
    lines = (f'<span style="border-left:2px solid {to_hex(PAYLOAD_COLOUR)};height:14px;width:0"></span>payload step'
             '<span style="border-left:2px dotted #737373;height:14px;width:0"></span>phase change')
    return f"<p class=key>On every time axis:{spans}{lines}</p>"


def _events_rows(flight: Flight) -> list[list[str]]:
    return [[f"{t:+.3f}", s["text"]] for t, s in zip(flight.time("events"), flight.samples("events"), strict=True)]


def page(flight: Flight, bounds: Bounds, figures: list[tuple[str, str, bytes]]) -> str:
    name = flight.scenario.get("name", flight.run_dir.name)
    sections = [result_section(flight, bounds), "<h2 id=scenario>Scenario</h2>", _table(scenario_rows(flight))]
    stats = _stats_rows(flight.metrics)
    sections += [f"<h2 id=metrics>Metrics (after the {bounds.settle_s:g} s settle time)</h2>",
                 _table(stats, ["figure", "axis", "min", "max", "RMS", "max |·|"]) if stats else "<p>none recorded</p>",
                 "<h2 id=timing-table>Timing</h2>",
                 _table(timing_rows(flight.metrics)) if flight.metrics.get("timing") else "<p>not recorded</p>",
                 _marker_key(), *(_figure_html(*f) for f in figures),
                 "<h2 id=events>Events (mission time, s)</h2>", _table(_events_rows(flight), ["t", "event"]),
                 "<h2 id=summary>summary.txt</h2>", f"<pre>{html.escape(flight.summary or 'not written')}</pre>"]
    nav = " ".join(f'<a href="#{a}">{t}</a>' for a, t in (("result", "result"), ("scenario", "scenario"),
                                                          ("metrics", "metrics"), ("trajectory", "figures"),
                                                          ("events", "events")))
    return ("<!DOCTYPE html><html lang=en><head><meta charset=utf-8>"
            f"<title>{html.escape(name)}: {html.escape(flight.run_dir.name)}</title><style>{STYLE}</style></head>"
            f"<body><h1>{html.escape(name)} <small>{html.escape(flight.run_dir.name)}</small></h1><nav>{nav}</nav>"
            + "".join(sections) + "</body></html>\n")


def write_report(run_dir: Path) -> Path:
    """Write RUN_DIR/report.html and return its path; raises NoFlightData (nothing written) when the run has
    no mission to show."""
    flight = load_flight(Path(run_dir))
    bounds = bounds_of(flight)
    text = page(flight, bounds, render(flight, bounds))
    out = Path(run_dir) / "report.html"
    partial = out.with_name(out.name + ".part")
    partial.write_text(text, encoding="utf-8")
    os.replace(partial, out)  # a reader never sees half a page
    return out
