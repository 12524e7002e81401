"""The drawing parts the report's figures share: the run as a view on the mission clock, markers for its gusts,
payload steps, faults and phase changes, thinning of long series, and PNG output with fixed margins.

matplotlib is imported in hil.reports only (never in the loop), with the non-interactive Agg backend.
"""

from __future__ import annotations

import io
import itertools
import math
import re
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import matplotlib

matplotlib.use("Agg")
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from firmware_interface.geodesy import LocalFrame
from hil.judge.planned_path import PlannedPath
from hil.reports.rundata import Flight
from hil.scenario.mission_items import PlanItem

DPI = 100
WIDTH_IN = 13.0
MAX_POINTS = 1600  # per line: min and max of each of 800 buckets, more than a half-width axes has pixel columns
NED = ("north", "east", "down")
RPY = ("roll", "pitch", "yaw")
TRUTH, COMMANDED, BOARD = "tab:blue", "tab:red", "tab:orange"
_OFFSET = re.compile(r"board frame: local origin offset \[([-+\d.]+), ([-+\d.]+), ([-+\d.]+)\] m")


@dataclass
class Bounds:
    """The expect bounds that apply to this run's board (PX4's replace the emulator's where the scenario sets
    them), on the mission clock from settle_s to the end of the mission."""

    settle_s: float
    mission_end_s: float
    max_error_m: tuple[float, float, float] | None = None
    max_attitude_error_deg: float | None = None
    min_realtime_factor: float | None = None


@dataclass
class Markers:
    """What happened when: spans (start, end, label) and instants (t, label), mission time, s."""

    phases: list[tuple[float, str]] = field(default_factory=list)
    gusts: list[tuple[float, float, str]] = field(default_factory=list)
    motor_faults: list[tuple[float, float, str]] = field(default_factory=list)
    sensor_faults: list[tuple[float, float, str]] = field(default_factory=list)
    link_faults: list[tuple[float, float, str]] = field(default_factory=list)
    payload_steps: list[tuple[float, str]] = field(default_factory=list)


SPAN_STYLE = {"gusts": ("tab:cyan", 0.18), "motor_faults": ("tab:red", 0.12), "sensor_faults": ("tab:brown", 0.12),
              "link_faults": ("tab:gray", 0.15)}
PAYLOAD_COLOUR, PHASE_COLOUR = "tab:purple", "0.45"


def markers_of(flight: Flight) -> Markers:
    """Gusts, faults and payload steps from the resolved scenario; phase changes from the state samples."""
    s, end = flight.scenario, float(flight.time("state")[-1])
    faults = s.get("faults", {})
    sensor_faults = [*s.get("sensors", {}).get("faults", []), *faults.get("sensors", [])]

    def until(value: float | None) -> float:
        return end if value is None or math.isinf(value) else float(value)

    phases, previous = [], None
    for t, sample in zip(flight.time("state"), flight.samples("state"), strict=True):
        if sample["phase"] != previous:
            phases.append((float(t), sample["phase"]))
            previous = sample["phase"]
    return Markers(
        phases=phases,
        gusts=[(g["start_s"], g["start_s"] + g["duration_s"], f"gust {i + 1}")
               for i, g in enumerate(s.get("wind", {}).get("gusts", []))],
        motor_faults=[(m["start_s"], until(m.get("end_s")), f"motor {m['motor']} at {m['health']:.0%}")
                      for m in faults.get("motors", [])] + _cell_failure(s, end),
        sensor_faults=[(f["start_s"], until(f.get("end_s")), f"{f['sensor']} {f['kind']}") for f in sensor_faults],
        link_faults=[(f["start_s"], until(f.get("end_s")), f"link {f['kind']}") for f in faults.get("link", [])]
        + [(f["start_s"], until(f.get("end_s")), "ground station lost") for f in faults.get("ground_station", [])]
        + [(f["start_s"], until(f.get("end_s")), "joystick lost")
           for f in (s.get("manual_control") or {}).get("loss", [])],
        payload_steps=[(p["t_s"], f"payload {p['mass_kg']:g} kg") for p in s.get("payload", [])],
    )


def _cell_failure(scenario: dict[str, Any], end: float) -> list[tuple[float, float, str]]:
    failure = (scenario.get("battery") or {}).get("failure")
    return [] if not failure else [(failure["t_s"], end, f"battery cell {failure['cell']} fails")]


def thin(t: np.ndarray, y: np.ndarray, max_points: int = MAX_POINTS) -> tuple[np.ndarray, np.ndarray]:
    """At most ~max_points samples of a long series, keeping each bucket's minimum and maximum: the plotted
    envelope (and so every peak an expect bound is judged on) is the full series'."""
    n = len(y)
    if n <= max_points:
        return t, y
    size = math.ceil(n / (max_points // 2))
    whole = n // size * size
    blocks = y[:whole].reshape(-1, size)
    starts = np.arange(0, whole, size)
    high = np.where(np.isnan(blocks), -np.inf, blocks).argmax(axis=1)
    low = np.where(np.isnan(blocks), np.inf, blocks).argmin(axis=1)
    keep = np.unique(np.concatenate((starts + high, starts + low, np.arange(whole, n))))
    return t[keep], y[keep]


def plot_line(ax: Axes, t: np.ndarray, y: np.ndarray, *args: Any, **kwargs: Any) -> None:
    ax.plot(*thin(t, y), *args, linewidth=kwargs.pop("linewidth", 1.0), **kwargs)


def merged_spans(spans: list[tuple[float, float, str]]) -> dict[tuple[float, float], str]:
    """Spans over the same times as one, their labels joined (four link faults over the whole flight are one
    shade, not four stacked)."""
    out: dict[tuple[float, float], str] = {}
    for start, end, label in spans:
        out[(start, end)] = f"{out[(start, end)]}, {label}" if (start, end) in out else label
    return out


def mark(ax: Axes, markers: Markers, labelled: bool) -> None:
    """Shade the spans and draw the instants on a time axis; `labelled` names them (the top axes only)."""
    for kind, (colour, alpha) in SPAN_STYLE.items():
        for (start, end), label in merged_spans(getattr(markers, kind)).items():
            ax.axvspan(start, end, color=colour, alpha=alpha, linewidth=0)
            if labelled:
                label_at(ax, start, label, colour)
    for t, label in markers.payload_steps:
        ax.axvline(t, color=PAYLOAD_COLOUR, linewidth=1.2)
        if labelled:
            label_at(ax, t, label, PAYLOAD_COLOUR)
    for t, _ in markers.phases[1:]:
        ax.axvline(t, color=PHASE_COLOUR, linestyle=":", linewidth=1.0)
    if labelled:
        for t, phase in markers.phases:
            label_at(ax, t, phase, PHASE_COLOUR)


def label_at(ax: Axes, t: float, text: str, colour: str) -> None:
    ax.text(t, 0.03, text, transform=ax.get_xaxis_transform(), rotation=90, va="bottom", ha="left", fontsize=7,
            color=colour, clip_on=True)  # at the foot: the legends sit at the top


def draw_bound(ax: Axes, bound: float, bounds: Bounds, what: str) -> None:
    """±bound as dashed lines over the window the expectation judges (settle time to the mission's end)."""
    ax.hlines((-bound, bound), bounds.settle_s, bounds.mission_end_s, colors="k", linestyles="--", linewidth=1.0,
              label=f"expect |{what}| ≤ {bound:g}")



def state_index(state_t_us: np.ndarray, t_us: np.ndarray) -> np.ndarray:
    """For each of a channel's sample times, the index of the state sample of the same step (−1 if none): every
    channel is stamped with its step's bench time."""
    if len(state_t_us) == 0:
        return np.full(len(t_us), -1)
    at = np.clip(np.searchsorted(state_t_us, t_us), 0, len(state_t_us) - 1)
    return np.where(state_t_us[at] == t_us, at, -1)


def board_offset_ned(flight: Flight) -> np.ndarray:
    """The board's local-frame origin minus the bench's, m, as the bench measured it at arming (its event);
    zero if the board sent no position before arming."""
    for sample in flight.samples("events"):
        found = _OFFSET.match(sample["text"])
        if found:
            return np.array([float(v) for v in found.groups()])
    return np.zeros(3)


@dataclass
class View:
    """The arrays the figures share, computed once per report."""

    flight: Flight
    bounds: Bounds
    markers: Markers
    t: np.ndarray  # mission time of each state sample, s
    t_us: np.ndarray  # bench time of each state sample, µs
    pos_ned: np.ndarray
    ref_ned: np.ndarray  # NaN where no reference was streamed
    rpy_rad: np.ndarray
    in_air: np.ndarray  # the plant's ground contact is off

    @classmethod
    def of(cls, flight: Flight, bounds: Bounds) -> View:
        t_us = np.array([s["t_us"] for s in flight.samples("state")], dtype=np.int64)
        ref = np.full((len(t_us), 3), np.nan)
        at = state_index(t_us, np.array([s["t_us"] for s in flight.samples("reference")], dtype=np.int64))
        if (at >= 0).any():  # a board flying its own mission streams no reference
            ref[at[at >= 0]] = flight.column("reference", "pos_ned")[at >= 0]
        return cls(flight, bounds, markers_of(flight), flight.time("state"), t_us, flight.column("state", "pos_ned"),
                   ref, flight.column("state", "rpy"), ~np.array([s["on_ground"] for s in flight.samples("state")]))

    @cached_property
    def planned_ned(self) -> np.ndarray | None:
        """The planned mission's positions in order (NED about home), for a board flying its own mission."""
        pilot = self.flight.scenario.get("pilot") or {}
        if not pilot.get("items"):
            return None
        home = self.flight.scenario.get("home") or {}
        frame = LocalFrame(home.get("lat_deg", 0.0), home.get("lon_deg", 0.0), home.get("alt_msl_m", 0.0))
        path = PlannedPath([PlanItem.model_validate(item) for item in pilot["items"]], frame)
        return np.array([path.points[seq] for seq in sorted(path.points)]) if path.points else None

    @cached_property
    def disturbance_in_air_ned(self) -> np.ndarray:
        """The true disturbance, N, NaN on the ground (there the ground's reaction would swamp the axis)."""
        return np.where(self.in_air[:, None], self.flight.true_disturbance_ned(), np.nan)

    def truth_at(self, channel: str) -> tuple[np.ndarray, np.ndarray]:
        """The channel's samples that share a step with a state sample: their positions in the channel and the
        state indices of those steps."""
        at = state_index(self.t_us, np.array([s["t_us"] for s in self.flight.samples(channel)], dtype=np.int64))
        return np.flatnonzero(at >= 0), at[at >= 0]


def new_figure(view: View, rows: int, height_in: float, cols: int = 1) -> tuple[Figure, np.ndarray]:
    """A figure of time axes sharing the flight's time range, each marked, the top ones labelled."""
    fig = Figure(figsize=(WIDTH_IN, height_in), dpi=DPI)
    axes = fig.subplots(rows, cols, sharex=True, squeeze=False)
    for (row, _), ax in np.ndenumerate(axes):
        mark(ax, view.markers, labelled=row == 0)
        ax.grid(True, linewidth=0.4)
        ax.set_xlim(view.t[0], view.t[-1])
        if row == rows - 1:
            ax.set_xlabel("mission time (s)")
    return fig, axes


def legend(ax: Axes) -> None:
    ax.legend(fontsize=7, loc="upper right", ncol=4, framealpha=0.8)


def wrap_deg(a: np.ndarray) -> np.ndarray:
    return (a + 180.0) % 360.0 - 180.0


def windowed(t: np.ndarray, y: np.ndarray, window_s: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Centre times and (median, p99, max) of y per window: a per-step series of wall times is noise drawn as a
    band; its percentiles per second show what a run's timing did and when."""
    edges = np.arange(t[0], t[-1] + window_s, window_s) if len(t) else np.zeros(0)
    bounds = np.searchsorted(t, edges)
    centres, stats = [], []
    for start, (a, b) in zip(edges, itertools.pairwise(bounds), strict=False):
        values = y[a:b][~np.isnan(y[a:b])]
        if len(values):
            centres.append(start + window_s / 2)
            stats.append(np.percentile(values, (50, 99, 100)))
    return np.array(centres), np.array(stats).reshape(-1, 3)


def png(fig: Figure) -> bytes:
    """The figure as PNG, with fixed margins in inches: tight_layout cost as much as drawing the figure."""
    width_in, height_in = fig.get_size_inches()
    fig.subplots_adjust(left=0.8 / width_in, right=1 - 0.2 / width_in, bottom=0.55 / height_in,
                        top=1 - 0.15 / height_in, wspace=0.16, hspace=0.1)
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=DPI)
    return buffer.getvalue()


