"""The figures of the one-page run report (`hil.reports.html`): the whole flight on the mission clock, with the
scenario's gusts, payload steps and faults and the bench's phase changes marked on every time axis, and the
`expect` bounds drawn where they apply. Each figure comes back as PNG bytes, to be embedded in the page.

matplotlib is imported in hil.reports only (never in the loop), with the non-interactive Agg backend.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import matplotlib

matplotlib.use("Agg")
import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import NullFormatter

from hil.reports.plotting import (
    BOARD,
    COMMANDED,
    DPI,
    MAX_POINTS,
    NED,
    RPY,
    TRUTH,
    WIDTH_IN,
    Bounds,
    View,
    board_offset_ned,
    draw_bound,
    legend,
    new_figure,
    plot_line,
    png,
    windowed,
    wrap_deg,
)
from hil.reports.rundata import G_NED_M_S2, Flight, rpy_from_quaternion


def trajectory(view: View) -> Figure:
    """3-D and north/east top view of the flown path against the reference, the whole flight."""
    fig = Figure(figsize=(WIDTH_IN, 5.5), dpi=DPI)
    step = max(1, math.ceil(len(view.t) / MAX_POINTS))
    flown, ref = view.pos_ned[::step], view.ref_ned[::step]
    planned = view.planned_ned
    if planned is not None and np.isnan(ref).all():  # a board flying its own mission: its plan, not a reference
        ref = planned
    label = "reference" if planned is None else "planned mission"
    ax3 = fig.add_subplot(1, 2, 1, projection="3d")
    ax3.plot(ref[:, 0], ref[:, 1], -ref[:, 2], color=TRUTH, label=label, marker="o" if planned is not None else "")
    ax3.plot(flown[:, 0], flown[:, 1], -flown[:, 2], color=COMMANDED, linestyle="--", label="flown (truth)")
    ax3.set_xlabel("north (m)")
    ax3.set_ylabel("east (m)")
    ax3.set_zlabel("height (m)")
    ax3.legend(fontsize=8)
    top = fig.add_subplot(1, 2, 2)
    top.plot(ref[:, 1], ref[:, 0], color=TRUTH, label=label, marker="o" if planned is not None else "")
    top.plot(flown[:, 1], flown[:, 0], color=COMMANDED, linestyle="--", linewidth=1.0, label="flown (truth)")
    top.plot(flown[0, 1], flown[0, 0], "go", label="start")
    top.plot(flown[-1, 1], flown[-1, 0], "ks", label="end")
    top.set_xlabel("east (m)")
    top.set_ylabel("north (m)")
    top.set_aspect("equal", adjustable="datalim")
    top.grid(True, linewidth=0.4)
    top.set_title("top view (north up)", fontsize=10)
    legend(top)
    return fig


def position_error(view: View) -> Figure | None:
    if np.isnan(view.ref_ned).all():  # no reference was streamed: a board flying its own mission
        return None
    fig, axes = new_figure(view, 3, 6.5)
    error = view.pos_ned - view.ref_ned
    for i, ax in enumerate(axes[:, 0]):
        plot_line(ax, view.t, error[:, i], color=COMMANDED, label="true position − reference")
        if view.bounds.max_error_m is not None:
            draw_bound(ax, view.bounds.max_error_m[i], view.bounds, f"e_{'xyz'[i]}")
        ax.set_ylabel(f"e {NED[i]} (m)")
        legend(ax)
    return fig


def attitude(view: View) -> Figure:
    """Left: true roll/pitch/yaw and the board's commanded attitude; right: true − commanded at each command."""
    fig, axes = new_figure(view, 3, 7.0, cols=2)
    t_cmd = view.flight.time("board/attitude_target")
    cmd = np.degrees(rpy_from_quaternion(view.flight.column("board/attitude_target", "q").reshape(-1, 4)))
    rows, at = view.truth_at("board/attitude_target")
    airborne = view.in_air[at]
    rows, at = rows[airborne], at[airborne]
    t_cmd, cmd = t_cmd[rows], cmd[rows]
    truth = np.degrees(view.rpy_rad)
    error = wrap_deg(truth[at] - cmd)
    for i in range(3):
        plot_line(axes[i, 0], view.t, truth[:, i], color=TRUTH, label="true")
        plot_line(axes[i, 0], t_cmd, cmd[:, i], color=COMMANDED, linestyle="--", label="commanded (ATTITUDE_TARGET)")
        axes[i, 0].set_ylabel(f"{RPY[i]} (deg)")
        plot_line(axes[i, 1], t_cmd, error[:, i], color=COMMANDED, label="true − commanded")
        axes[i, 1].set_ylabel(f"{RPY[i]} error (deg)")
        if i < 2 and view.bounds.max_attitude_error_deg is not None:
            draw_bound(axes[i, 1], view.bounds.max_attitude_error_deg, view.bounds, "roll/pitch error")
        legend(axes[i, 0])
        legend(axes[i, 1])
    return fig


QUAD_X_NAMES = (" (front-right)", " (rear-left)", " (front-left)", " (rear-right)")  # PX4's quad X


def motors(view: View) -> Figure:
    fig, axes = new_figure(view, 2, 5.5)
    t_act, commands = view.flight.time("actuators"), view.flight.column("actuators", "motors")
    t_env, health = view.flight.time("environment"), view.flight.column("environment", "motor_health")
    where = QUAD_X_NAMES if commands.shape[1] == len(QUAD_X_NAMES) else ("",) * commands.shape[1]
    for i in range(commands.shape[1]):  # PX4's motor order, as the plant's mapping lists its rotors
        plot_line(axes[0, 0], t_act, commands[:, i], color=f"C{i}", label=f"motor {i + 1}{where[i]}")
        if np.nanmin(health[:, i], initial=1.0) < 1.0:
            plot_line(axes[0, 0], t_env, health[:, i], color=f"C{i}", linestyle="--", label=f"motor {i + 1} health")
    axes[0, 0].set_ylabel("command (0..1)")
    thrust = view.flight.column("state", "thrust_total")
    weight = view.flight.column("state", "total_mass") * G_NED_M_S2[2]
    plot_line(axes[1, 0], view.t, thrust, color=TRUTH, label="total rotor thrust (truth)")
    plot_line(axes[1, 0], view.t, weight, color="k", linestyle="--", label="weight m·g")
    axes[1, 0].set_ylabel("force (N)")
    legend(axes[0, 0])
    legend(axes[1, 0])
    return fig


def wind_and_disturbance(view: View) -> Figure:
    """The wind, and the true disturbance (everything but thrust and gravity, in the air) beside the scripted
    force: for a wind scenario the scripted force is zero and the true one is the drag and rotor aerodynamics."""
    fig, axes = new_figure(view, 4, 8.5)
    t_env = view.flight.time("environment")
    wind = view.flight.column("environment", "wind_ned").reshape(-1, 3)
    scripted = view.flight.column("environment", "force_ned").reshape(-1, 3)
    true = view.disturbance_in_air_ned
    for i in range(3):
        plot_line(axes[0, 0], t_env, wind[:, i], color=f"C{i}", label=f"wind {NED[i]}")
        plot_line(axes[i + 1, 0], view.t, true[:, i], color=TRUTH, label="true disturbance (in the air)")
        plot_line(axes[i + 1, 0], t_env, scripted[:, i], color=COMMANDED, linestyle="--",
              label="scripted force (environment)")
        axes[i + 1, 0].set_ylabel(f"d {NED[i]} (N)")
        legend(axes[i + 1, 0])
    axes[0, 0].set_ylabel("wind (m/s)")
    legend(axes[0, 0])
    return fig


def board_estimates(view: View) -> Figure | None:
    """The board's LOCAL_POSITION_NED (its arming offset removed) and ATTITUDE against the truth."""
    flight = view.flight
    if not flight.samples("board/local_position_ned") and not flight.samples("board/attitude"):
        return None
    fig, axes = new_figure(view, 3, 7.0, cols=2)
    t_pos = flight.time("board/local_position_ned")
    pos = flight.column("board/local_position_ned", "pos_ned").reshape(-1, 3) - board_offset_ned(flight)
    t_att = flight.time("board/attitude")
    att = np.degrees(flight.column("board/attitude", "rpy").reshape(-1, 3))
    truth_deg = np.degrees(view.rpy_rad)
    for i in range(3):
        plot_line(axes[i, 0], view.t, view.pos_ned[:, i], color=TRUTH, label="true")
        plot_line(axes[i, 0], t_pos, pos[:, i], color=BOARD, linestyle="--",
                  label="board (LOCAL_POSITION_NED − offset)")
        axes[i, 0].set_ylabel(f"{NED[i]} (m)")
        plot_line(axes[i, 1], view.t, truth_deg[:, i], color=TRUTH, label="true")
        plot_line(axes[i, 1], t_att, att[:, i], color=BOARD, linestyle="--", label="board (ATTITUDE)")
        axes[i, 1].set_ylabel(f"{RPY[i]} (deg)")
        legend(axes[i, 0])
        legend(axes[i, 1])
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
    fig, axes = new_figure(view, len(rows), 2.2 * len(rows) + 0.8)
    t_est = flight.time("board/estimates")
    true = view.disturbance_in_air_ned
    for ax, key in zip(axes[:, 0], rows, strict=True):
        values = np.array([s["values"].get(key, np.nan) for s in flight.samples("board/estimates")])
        if key == "m_hat":
            plot_line(ax, view.t, flight.column("state", "total_mass"), color=TRUTH, label="true mass")
            ax.set_ylabel("mass (kg)")
        else:
            axis = "xyz".index(key[-1])
            plot_line(ax, view.t, true[:, axis], color=TRUTH, label="true disturbance (in the air)")
            ax.set_ylabel(f"d {NED[axis]} (N)")
        plot_line(ax, t_est, values, color=BOARD, linestyle="--", label=f"{key} (board)")
        legend(ax)
    return fig


def gps(view: View) -> Figure | None:
    flight = view.flight
    if not flight.samples("sensors/gps"):
        return None
    fig, axes = new_figure(view, 3, 6.0)
    t = flight.time("sensors/gps")
    satellites, eph, epv = (flight.column("sensors/gps", k) for k in ("satellites", "eph_m", "epv_m"))
    axes[0, 0].step(t, flight.column("sensors/gps", "fix_type"), where="post", color=TRUTH)
    axes[0, 0].set(ylabel="fix type (3 = 3D)", ylim=(-0.3, 6.3), yticks=range(7))
    axes[1, 0].step(t, satellites, where="post", color=TRUTH)
    axes[1, 0].set(ylabel="satellites", ylim=(0, np.nanmax(satellites, initial=0) + 2))
    plot_line(axes[2, 0], t, eph, color=TRUTH, label="eph (horizontal, 1 σ)")
    plot_line(axes[2, 0], t, epv, color=COMMANDED, linestyle="--", label="epv (vertical, 1 σ)")
    axes[2, 0].set(ylabel="accuracy (m)", ylim=(0, 1.25 * np.nanmax(np.r_[eph, epv], initial=0) + 0.1))
    legend(axes[2, 0])
    return fig


def battery(view: View) -> Figure | None:
    """The battery as the bench reported it to the board: pack voltage (and each cell), current, charge left with
    the board's thresholds (the scenario's board.params, else PX4's defaults)."""
    flight = view.flight
    if not flight.samples("battery"):
        return None
    fig, axes = new_figure(view, 3, 6.5)
    t = flight.time("battery")
    plot_line(axes[0, 0], t, flight.column("battery", "voltage_v"), color=TRUTH, label="pack")
    axes[0, 0].set_ylabel("voltage (V)")
    plot_line(axes[1, 0], t, flight.column("battery", "current_a"), color=TRUTH, label="current (discharging)")
    axes[1, 0].set_ylabel("current (A)")
    plot_line(axes[2, 0], t, 100 * flight.column("battery", "remaining"), color=TRUTH, label="charge left")
    params = flight.scenario.get("board", {}).get("params", {})
    for name, default, style in (("BAT_LOW_THR", 0.15, ":"), ("BAT_CRIT_THR", 0.07, "--"),
                                 ("BAT_EMERGEN_THR", 0.05, "-.")):
        axes[2, 0].axhline(100 * params.get(name, default), color=COMMANDED, linestyle=style, linewidth=1.0,
                           label=name)
    axes[2, 0].set_ylabel("charge (%)")
    for ax in axes[:, 0]:
        legend(ax)
    return fig


def sticks(view: View) -> Figure | None:
    """The stick positions of the MANUAL_CONTROL messages sent (none sent in a loss)."""
    flight = view.flight
    if not flight.samples("manual_control"):
        return None
    fig, axes = new_figure(view, 1, 3.0)
    t = flight.time("manual_control")
    for name, colour in zip(("pitch", "roll", "throttle", "yaw"), (TRUTH, COMMANDED, "tab:green", BOARD), strict=True):
        axes[0, 0].plot(t, flight.column("manual_control", name), ".", markersize=2, color=colour, label=name)
    axes[0, 0].set(ylabel="stick (-1..1)", ylim=(-1.1, 1.1))
    legend(axes[0, 0])
    return fig


def timing(view: View) -> Figure:
    """Wall time per step against the simulated step (below it the bench runs faster than real time), and the
    sensor → actuator round trip, as percentiles per second."""
    fig, axes = new_figure(view, 2, 5.0)
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
        legend(ax)
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
    ("Battery", ("The plant's battery as each BATTERY_STATUS sent to the board carried it: pack voltage, current, "
     "charge left, against the board's battery thresholds."), battery),
    ("Sticks", "The stick positions of each MANUAL_CONTROL sent to the board (gaps: the joystick lost).", sticks),
    ("Timing", ("Wall time of the bench's steps against the simulated step (below it: faster than real time), and "
     "the sensor → actuator round trip: median, p99 and max per second, log scales."), timing),
)


def render(flight: Flight, bounds: Bounds) -> list[tuple[str, str, bytes]]:
    """(title, caption, PNG) of every figure the run has data for."""
    view = View.of(flight, bounds)
    out = []
    for title, caption, build in FIGURES:
        fig = build(view)
        if fig is not None:
            out.append((title, caption, png(fig)))
    return out
