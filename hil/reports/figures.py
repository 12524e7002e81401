"""The figures of the one-page run report (`hil.reports.html`): the whole flight on the mission clock, with the
scenario's gusts, payload steps and faults and the bench's phase changes marked on every time axis, and the
`expect` bounds drawn where they apply. Each figure comes back as PNG bytes, to be embedded in the page.

matplotlib is imported here and in hil.reports.png only (never in the loop), with the non-interactive Agg backend.
"""

from __future__ import annotations

import io
import itertools
import math
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import matplotlib

matplotlib.use("Agg")
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.ticker import NullFormatter

from hil.reports.rundata import G_NED_M_S2, Flight, rpy_from_quaternion

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
                      for m in faults.get("motors", [])],
        sensor_faults=[(f["start_s"], until(f.get("end_s")), f"{f['sensor']} {f['kind']}") for f in sensor_faults],
        link_faults=[(f["start_s"], until(f.get("end_s")), f"link {f['kind']}") for f in faults.get("link", [])],
        payload_steps=[(p["t_s"], f"payload {p['mass_kg']:g} kg") for p in s.get("payload", [])],
    )


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


def _plot(ax: Axes, t: np.ndarray, y: np.ndarray, *args: Any, **kwargs: Any) -> None:
    ax.plot(*thin(t, y), *args, linewidth=kwargs.pop("linewidth", 1.0), **kwargs)


def _merged(spans: list[tuple[float, float, str]]) -> dict[tuple[float, float], str]:
    """Spans over the same times as one, their labels joined (four link faults over the whole flight are one
    shade, not four stacked)."""
    out: dict[tuple[float, float], str] = {}
    for start, end, label in spans:
        out[(start, end)] = f"{out[(start, end)]}, {label}" if (start, end) in out else label
    return out


def mark(ax: Axes, markers: Markers, labelled: bool) -> None:
    """Shade the spans and draw the instants on a time axis; `labelled` names them (the top axes only)."""
    for kind, (colour, alpha) in SPAN_STYLE.items():
        for (start, end), label in _merged(getattr(markers, kind)).items():
            ax.axvspan(start, end, color=colour, alpha=alpha, linewidth=0)
            if labelled:
                _label(ax, start, label, colour)
    for t, label in markers.payload_steps:
        ax.axvline(t, color=PAYLOAD_COLOUR, linewidth=1.2)
        if labelled:
            _label(ax, t, label, PAYLOAD_COLOUR)
    for t, _ in markers.phases[1:]:
        ax.axvline(t, color=PHASE_COLOUR, linestyle=":", linewidth=1.0)
    if labelled:
        for t, phase in markers.phases:
            _label(ax, t, phase, PHASE_COLOUR)


def _label(ax: Axes, t: float, text: str, colour: str) -> None:
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
        ref[at[at >= 0]] = flight.column("reference", "pos_ned")[at >= 0]
        return cls(flight, bounds, markers_of(flight), flight.time("state"), t_us, flight.column("state", "pos_ned"),
                   ref, flight.column("state", "rpy"), ~np.array([s["on_ground"] for s in flight.samples("state")]))

    @cached_property
    def disturbance_in_air_ned(self) -> np.ndarray:
        """The true disturbance, N, NaN on the ground (there the ground's reaction would swamp the axis)."""
        return np.where(self.in_air[:, None], self.flight.true_disturbance_ned(), np.nan)

    def truth_at(self, channel: str) -> tuple[np.ndarray, np.ndarray]:
        """The channel's samples that share a step with a state sample: their positions in the channel and the
        state indices of those steps."""
        at = state_index(self.t_us, np.array([s["t_us"] for s in self.flight.samples(channel)], dtype=np.int64))
        return np.flatnonzero(at >= 0), at[at >= 0]


def _figure(view: View, rows: int, height_in: float, cols: int = 1) -> tuple[Figure, np.ndarray]:
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


def _legend(ax: Axes) -> None:
    ax.legend(fontsize=7, loc="upper right", ncol=4, framealpha=0.8)


def _wrap_deg(a: np.ndarray) -> np.ndarray:
    return (a + 180.0) % 360.0 - 180.0


def trajectory(view: View) -> Figure:
    """3-D and north/east top view of the flown path against the reference, the whole flight."""
    fig = Figure(figsize=(WIDTH_IN, 5.5), dpi=DPI)
    step = max(1, math.ceil(len(view.t) / MAX_POINTS))
    flown, ref = view.pos_ned[::step], view.ref_ned[::step]
    ax3 = fig.add_subplot(1, 2, 1, projection="3d")
    ax3.plot(ref[:, 0], ref[:, 1], -ref[:, 2], color=TRUTH, label="reference")
    ax3.plot(flown[:, 0], flown[:, 1], -flown[:, 2], color=COMMANDED, linestyle="--", label="flown (truth)")
    ax3.set_xlabel("north (m)")
    ax3.set_ylabel("east (m)")
    ax3.set_zlabel("height (m)")
    ax3.legend(fontsize=8)
    top = fig.add_subplot(1, 2, 2)
    top.plot(ref[:, 1], ref[:, 0], color=TRUTH, label="reference")
    top.plot(flown[:, 1], flown[:, 0], color=COMMANDED, linestyle="--", linewidth=1.0, label="flown (truth)")
    top.plot(flown[0, 1], flown[0, 0], "go", label="start")
    top.plot(flown[-1, 1], flown[-1, 0], "ks", label="end")
    top.set_xlabel("east (m)")
    top.set_ylabel("north (m)")
    top.set_aspect("equal", adjustable="datalim")
    top.grid(True, linewidth=0.4)
    top.set_title("top view (north up)", fontsize=10)
    _legend(top)
    return fig


def position_error(view: View) -> Figure:
    fig, axes = _figure(view, 3, 6.5)
    error = view.pos_ned - view.ref_ned
    for i, ax in enumerate(axes[:, 0]):
        _plot(ax, view.t, error[:, i], color=COMMANDED, label="true position − reference")
        if view.bounds.max_error_m is not None:
            draw_bound(ax, view.bounds.max_error_m[i], view.bounds, f"e_{'xyz'[i]}")
        ax.set_ylabel(f"e {NED[i]} (m)")
        _legend(ax)
    return fig


def attitude(view: View) -> Figure:
    """Left: true roll/pitch/yaw and the board's commanded attitude; right: true − commanded at each command."""
    fig, axes = _figure(view, 3, 7.0, cols=2)
    t_cmd = view.flight.time("board/attitude_target")
    cmd = np.degrees(rpy_from_quaternion(view.flight.column("board/attitude_target", "q").reshape(-1, 4)))
    rows, at = view.truth_at("board/attitude_target")
    airborne = view.in_air[at]
    rows, at = rows[airborne], at[airborne]
    t_cmd, cmd = t_cmd[rows], cmd[rows]
    truth = np.degrees(view.rpy_rad)
    error = _wrap_deg(truth[at] - cmd)
    for i in range(3):
        _plot(axes[i, 0], view.t, truth[:, i], color=TRUTH, label="true")
        _plot(axes[i, 0], t_cmd, cmd[:, i], color=COMMANDED, linestyle="--", label="commanded (ATTITUDE_TARGET)")
        axes[i, 0].set_ylabel(f"{RPY[i]} (deg)")
        _plot(axes[i, 1], t_cmd, error[:, i], color=COMMANDED, label="true − commanded")
        axes[i, 1].set_ylabel(f"{RPY[i]} error (deg)")
        if i < 2 and view.bounds.max_attitude_error_deg is not None:
            draw_bound(axes[i, 1], view.bounds.max_attitude_error_deg, view.bounds, "roll/pitch error")
        _legend(axes[i, 0])
        _legend(axes[i, 1])
    return fig


def motors(view: View) -> Figure:
    fig, axes = _figure(view, 2, 5.5)
    t_act, commands = view.flight.time("actuators"), view.flight.column("actuators", "motors").reshape(-1, 4)
    t_env, health = view.flight.time("environment"), view.flight.column("environment", "motor_health").reshape(-1, 4)
    names = ("front-right", "rear-left", "front-left", "rear-right")
    for i in range(4):
        _plot(axes[0, 0], t_act, commands[:, i], color=f"C{i}", label=f"motor {i + 1} ({names[i]})")
        if np.nanmin(health[:, i], initial=1.0) < 1.0:
            _plot(axes[0, 0], t_env, health[:, i], color=f"C{i}", linestyle="--", label=f"motor {i + 1} health")
    axes[0, 0].set_ylabel("command (0..1)")
    thrust = view.flight.column("state", "thrust_total")
    weight = view.flight.column("state", "total_mass") * G_NED_M_S2[2]
    _plot(axes[1, 0], view.t, thrust, color=TRUTH, label="total rotor thrust (truth)")
    _plot(axes[1, 0], view.t, weight, color="k", linestyle="--", label="weight m·g")
    axes[1, 0].set_ylabel("force (N)")
    _legend(axes[0, 0])
    _legend(axes[1, 0])
    return fig


def wind_and_disturbance(view: View) -> Figure:
    """The wind, and the true disturbance (everything but thrust and gravity, in the air) beside the scripted
    force: for a wind scenario the scripted force is zero and the true one is the drag and rotor aerodynamics."""
    fig, axes = _figure(view, 4, 8.5)
    t_env = view.flight.time("environment")
    wind = view.flight.column("environment", "wind_ned").reshape(-1, 3)
    scripted = view.flight.column("environment", "force_ned").reshape(-1, 3)
    true = view.disturbance_in_air_ned
    for i in range(3):
        _plot(axes[0, 0], t_env, wind[:, i], color=f"C{i}", label=f"wind {NED[i]}")
        _plot(axes[i + 1, 0], view.t, true[:, i], color=TRUTH, label="true disturbance (in the air)")
        _plot(axes[i + 1, 0], t_env, scripted[:, i], color=COMMANDED, linestyle="--",
              label="scripted force (environment)")
        axes[i + 1, 0].set_ylabel(f"d {NED[i]} (N)")
        _legend(axes[i + 1, 0])
    axes[0, 0].set_ylabel("wind (m/s)")
    _legend(axes[0, 0])
    return fig


def board_estimates(view: View) -> Figure | None:
    """The board's LOCAL_POSITION_NED (its arming offset removed) and ATTITUDE against the truth."""
    flight = view.flight
    if not flight.samples("board/local_position_ned") and not flight.samples("board/attitude"):
        return None
    fig, axes = _figure(view, 3, 7.0, cols=2)
    t_pos = flight.time("board/local_position_ned")
    pos = flight.column("board/local_position_ned", "pos_ned").reshape(-1, 3) - board_offset_ned(flight)
    t_att = flight.time("board/attitude")
    att = np.degrees(flight.column("board/attitude", "rpy").reshape(-1, 3))
    truth_deg = np.degrees(view.rpy_rad)
    for i in range(3):
        _plot(axes[i, 0], view.t, view.pos_ned[:, i], color=TRUTH, label="true")
        _plot(axes[i, 0], t_pos, pos[:, i], color=BOARD, linestyle="--", label="board (LOCAL_POSITION_NED − offset)")
        axes[i, 0].set_ylabel(f"{NED[i]} (m)")
        _plot(axes[i, 1], view.t, truth_deg[:, i], color=TRUTH, label="true")
        _plot(axes[i, 1], t_att, att[:, i], color=BOARD, linestyle="--", label="board (ATTITUDE)")
        axes[i, 1].set_ylabel(f"{RPY[i]} (deg)")
        _legend(axes[i, 0])
        _legend(axes[i, 1])
    return fig


def controller_internals(view: View) -> Figure | None:
    """The controller's own estimates where it has them: m̂ against the true mass, d̂ against the true
    disturbance."""
    flight = view.flight
    keys = {k for s in flight.samples("board/estimates") for k in s["values"]}
    d_keys = [k for k in ("d_hat_x", "d_hat_y", "d_hat_z") if k in keys]
    rows = ["m_hat"] * ("m_hat" in keys) + d_keys
    if not rows:
        return None
    fig, axes = _figure(view, len(rows), 2.2 * len(rows) + 0.8)
    t_est = flight.time("board/estimates")
    true = view.disturbance_in_air_ned
    for ax, key in zip(axes[:, 0], rows, strict=True):
        values = np.array([s["values"].get(key, np.nan) for s in flight.samples("board/estimates")])
        if key == "m_hat":
            _plot(ax, view.t, flight.column("state", "total_mass"), color=TRUTH, label="true mass")
            ax.set_ylabel("mass (kg)")
        else:
            axis = "xyz".index(key[-1])
            _plot(ax, view.t, true[:, axis], color=TRUTH, label="true disturbance (in the air)")
            ax.set_ylabel(f"d {NED[axis]} (N)")
        _plot(ax, t_est, values, color=BOARD, linestyle="--", label=f"{key} (board)")
        _legend(ax)
    return fig


def gps(view: View) -> Figure | None:
    flight = view.flight
    if not flight.samples("sensors/gps"):
        return None
    fig, axes = _figure(view, 3, 6.0)
    t = flight.time("sensors/gps")
    satellites, eph, epv = (flight.column("sensors/gps", k) for k in ("satellites", "eph_m", "epv_m"))
    axes[0, 0].step(t, flight.column("sensors/gps", "fix_type"), where="post", color=TRUTH)
    axes[0, 0].set(ylabel="fix type (3 = 3D)", ylim=(-0.3, 6.3), yticks=range(7))
    axes[1, 0].step(t, satellites, where="post", color=TRUTH)
    axes[1, 0].set(ylabel="satellites", ylim=(0, np.nanmax(satellites, initial=0) + 2))
    _plot(axes[2, 0], t, eph, color=TRUTH, label="eph (horizontal, 1 σ)")
    _plot(axes[2, 0], t, epv, color=COMMANDED, linestyle="--", label="epv (vertical, 1 σ)")
    axes[2, 0].set(ylabel="accuracy (m)", ylim=(0, 1.25 * np.nanmax(np.r_[eph, epv], initial=0) + 0.1))
    _legend(axes[2, 0])
    return fig


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


def timing(view: View) -> Figure:
    """Wall time per step against the simulated step (below it the bench runs faster than real time), and the
    sensor → actuator round trip, as percentiles per second."""
    fig, axes = _figure(view, 2, 5.0)
    t = view.flight.time("timing")
    period_us = 1e6 / float(view.flight.scenario["rate_hz"])
    series = (("step_wall_us", "wall time of a step", "step (µs)"),
              ("round_trip_us", "sensor frame sent → actuator reply", "round trip (µs)"))
    for ax, (key, what, ylabel) in zip(axes[:, 0], series, strict=True):
        centres, stats = windowed(t, view.flight.column("timing", key))
        for column, (name, style) in enumerate((("median", "-"), ("p99", "--"), ("max", ":"))):
            ax.plot(centres, stats[:, column], color=TRUTH, linestyle=style, linewidth=1.0, label=f"{what}: {name}")
        ax.set_ylabel(ylabel)
        ax.set_yscale("log")
        ax.yaxis.set_minor_formatter(NullFormatter())
    axes[0, 0].axhline(period_us, color="k", linewidth=1.0, label=f"simulated step {period_us:g} µs (real time)")
    for ax in axes[:, 0]:
        _legend(ax)
    return fig


Builder = Callable[[View], Figure | None]
FIGURES: tuple[tuple[str, str, Builder], ...] = (
    ("Trajectory", ("Reference (blue) and the true flown path (red dashed), the whole flight; right: seen from "
     "above, north up."), trajectory),
    ("Position error", ("True position − reference, NED. Dashed black: the expect bound over the window it judges "
     "(settle time to the end of the mission)."), position_error),
    ("Attitude against the commanded attitude", ("Left: true roll, pitch, yaw and the board's ATTITUDE_TARGET. "
     "Right: true − commanded at each command, with the expect bound on roll and pitch. Commands in the air only (on "
     "the ground a board's command means nothing)."), attitude),
    ("Motors", ("The board's motor commands (dashed: a motor's health where a fault lowers it); total rotor thrust "
     "against the weight."), motors),
    ("Wind and disturbance", ("Wind (air velocity, NED). Below: the true disturbance d = m·(a − g) − R(q)·(0, 0, −T), "
     "every force on the vehicle but rotor thrust and gravity (drag, rotor aerodynamics, scripted forces), in the "
     "air only, beside the environment's scripted force."), wind_and_disturbance),
    ("The board's estimates against the truth", ("The board's position estimate (LOCAL_POSITION_NED, its frame's "
     "offset at arming removed) and attitude estimate (ATTITUDE) against the true state."), board_estimates),
    ("Controller internals", ("The controller's mass estimate m̂ against the true mass, and its disturbance "
     "estimate d̂ against the true disturbance."), controller_internals),
    ("GPS", "Fix type, satellites and the reported accuracies of the fixes sent to the board.", gps),
    ("Timing", ("Wall time of the bench's steps against the simulated step (below it: faster than real time), and "
     "the sensor → actuator round trip: median, p99 and max per second, log scales."), timing),
)


def png(fig: Figure) -> bytes:
    """The figure as PNG, with fixed margins in inches: tight_layout cost as much as drawing the figure."""
    width_in, height_in = fig.get_size_inches()
    fig.subplots_adjust(left=0.8 / width_in, right=1 - 0.2 / width_in, bottom=0.55 / height_in,
                        top=1 - 0.15 / height_in, wspace=0.16, hspace=0.1)
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=DPI)
    return buffer.getvalue()


def render(flight: Flight, bounds: Bounds) -> list[tuple[str, str, bytes]]:
    """(title, caption, PNG) of every figure the run has data for."""
    view = View.of(flight, bounds)
    out = []
    for title, caption, build in FIGURES:
        fig = build(view)
        if fig is not None:
            out.append((title, caption, png(fig)))
    return out
