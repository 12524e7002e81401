"""`hil report RUN_DIR`: PNG figures like the paper's Figures 5–18, and overlays for comparisons.

By default in the bench's frame (NED, roll/pitch/yaw of FRD), labelled as such; with `paper_frame` as the paper
draws them: z up, its angles γ, θ, ψ, titles with its figure number for the controller. The paper's frame is
NED reflected in z (x = north, y = east, z = −down: the helix x = cos(t/2), y = sin(t/2), z = t is flown as
north, east, up), so γ = −roll, θ = −pitch, ψ = yaw (tests/test_paper_frames.py derives this).

matplotlib is imported by the report modules only (here and hil.reports.figures; never in the loop), with the
non-interactive Agg backend.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import matplotlib.ticker
import numpy as np

from firmware_interface.geodesy import STANDARD_GRAVITY_M_S2
from hil.reports.rundata import RunData, load_run

G = STANDARD_GRAVITY_M_S2
Z_LINEAR_BELOW_M = 0.05  # the z overlay is linear inside ±5 cm, logarithmic beyond: a 0.24 m sag beside 3 m


@dataclass(frozen=True)
class Frame:
    """How the figures draw positions and angles."""

    name: str
    axes: tuple[str, str, str]
    angles: tuple[str, str, str]
    position_sign: tuple[float, float, float]
    angle_sign: tuple[float, float, float]
    paper_numbers: bool  # titles carry the paper's figure numbers (else "cf. Fig. N")

    def position(self, ned: np.ndarray) -> np.ndarray:
        return ned * np.array(self.position_sign)

    def attitude(self, rpy: np.ndarray) -> np.ndarray:
        return rpy * np.array(self.angle_sign)


NED_FRAME = Frame("NED", ("x north", "y east", "z down"), ("roll", "pitch", "yaw"), (1, 1, 1), (1, 1, 1), False)
PAPER_FRAME = Frame("the paper's frame, z up", ("x", "y", "z (up)"), ("γ", "θ", "ψ"), (1, 1, -1), (-1, -1, 1), True)

# the paper's simulation figures per controller (§4: SMARC; §5.1 sliding mode PID; §5.2 backstepping)
PAPER_FIGURES: dict[str, dict[str, int]] = {
    "smarc": {"trajectory": 5, "position_error": 6, "attitude": 7, "thrust": 8, "mass_estimate": 9,
              "disturbance_estimate": 10},
    "smpid": {"trajectory": 12, "position_error": 13, "attitude": 14},
    "backstepping": {"trajectory": 16, "position_error": 17, "attitude": 18},
}


def _save(fig: plt.Figure, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _title(data: RunData, frame: Frame, what: str, key: str) -> str:
    number = PAPER_FIGURES.get(data.controller, {}).get(key)
    if frame.paper_numbers:
        figure = f"Fig. {number}" if number else "no figure in the paper"
        return f"{figure} ({data.controller}, {data.name}): {what}, {frame.name}"
    return f"{data.name}, {data.controller}: {what}, {frame.name}" + (f" (cf. Fig. {number})" if number else "")


def _name(data: RunData, frame: Frame, key: str) -> str:
    """fig5_trajectory.png in the bench's frame (the SMARC numbers, whatever the controller); in the paper's frame
    the controller's own figure number, or the bare name where the paper has none."""
    number = (PAPER_FIGURES.get(data.controller, {}).get(key) if frame.paper_numbers
              else PAPER_FIGURES["smarc"][key])
    return f"fig{number}_{key}.png" if number else f"{key}.png"


def payload_steps(data: RunData) -> np.ndarray:
    """Mission times at which the true mass changed."""
    return data.t[1:][np.diff(data.mass) != 0]


def _mark(ax: plt.Axes, data: RunData, labelled: bool) -> None:
    """Mass steps (purple) and the settle time (grey, dotted) on a time axis."""
    settle = data.metrics.get("settle_s")
    if settle is not None:
        ax.axvline(settle, color="0.5", linestyle=":", linewidth=1, label="settle time" if labelled else None)
    for i, t in enumerate(payload_steps(data)):
        ax.axvline(t, color="tab:purple", linewidth=1, label="mass step" if labelled and i == 0 else None)


def _time_axes(rows: int, height: float) -> tuple[plt.Figure, np.ndarray]:
    fig, axes = plt.subplots(rows, 1, figsize=(7, height), sharex=True)
    return fig, np.atleast_1d(axes)


def figure_trajectory(data: RunData, out: Path, frame: Frame = NED_FRAME) -> Path:
    fig = plt.figure(figsize=(6, 5))
    ax = fig.add_subplot(projection="3d")
    ax.plot(data.ref[:, 0], data.ref[:, 1], -data.ref[:, 2], "b-", label="reference")  # height up in either frame
    ax.plot(data.pos[:, 0], data.pos[:, 1], -data.pos[:, 2], "r--", label="flown")
    ax.set_xlabel(f"{frame.axes[0]} (m)")
    ax.set_ylabel(f"{frame.axes[1]} (m)")
    ax.set_zlabel("height (m)")
    ax.set_title(_title(data, frame, "trajectory", "trajectory"), fontsize=9)
    ax.legend()
    return _save(fig, out / _name(data, frame, "trajectory"))


def _per_axis(data: RunData, out: Path, frame: Frame, key: str, what: str, ylabel: str,
              draw: Callable[[plt.Axes, int], object]) -> Path:
    """Three stacked axes on the mission clock, one per position axis of `frame`, each drawn by `draw`."""
    fig, axes = _time_axes(3, 6)
    for i, ax in enumerate(axes):
        draw(ax, i)
        _mark(ax, data, labelled=i == 0)
        ax.set_ylabel(ylabel.format(axis=frame.axes[i]))
        ax.grid(True)
    axes[0].legend(fontsize=7)
    axes[0].set_title(_title(data, frame, what, key), fontsize=9)
    axes[-1].set_xlabel("mission time (s)")
    return _save(fig, out / _name(data, frame, key))


def figure_errors(data: RunData, out: Path, frame: Frame = NED_FRAME) -> Path:
    error = frame.position(data.error)
    return _per_axis(data, out, frame, "position_error", "position error", "e {axis} (m)",
                     lambda ax, i: ax.plot(data.t, error[:, i], "r-", linewidth=1))


def attitude_error(data: RunData, frame: Frame = NED_FRAME) -> np.ndarray:
    """Flown − commanded at each command (deg), the flown angle taken at the command's step."""
    flown = np.column_stack([np.interp(data.cmd_t, data.t, data.rpy[:, i]) for i in range(3)])
    error = (flown - data.cmd_rpy + np.pi) % (2 * np.pi) - np.pi
    return np.degrees(frame.attitude(error))


def figure_attitude(data: RunData, out: Path, frame: Frame = NED_FRAME) -> Path:
    """Commanded and flown angles, then the errors: roll and pitch on one scale, yaw on its own."""
    fig, axes = _time_axes(5, 9)
    cmd, flown = np.degrees(frame.attitude(data.cmd_rpy)), np.degrees(frame.attitude(data.rpy))
    for i in range(3):
        axes[i].plot(data.cmd_t, cmd[:, i], "b-", label="commanded")
        axes[i].plot(data.t, flown[:, i], "r--", label="flown")
        axes[i].set_ylabel(f"{frame.angles[i]} (deg)")
    error = attitude_error(data, frame)
    for i in range(2):
        axes[3].plot(data.cmd_t, error[:, i], linewidth=1, label=f"e {frame.angles[i]}")
    axes[3].set_ylabel("error (deg)")
    axes[4].plot(data.cmd_t, error[:, 2], "g-", linewidth=1, label=f"e {frame.angles[2]}")
    axes[4].set_ylabel(f"e {frame.angles[2]} (deg)")
    settled = data.cmd_t >= data.metrics.get("settle_s", 0.0)
    for ax, columns in ((axes[3], [0, 1]), (axes[4], [2])):
        if settled.any():  # the start transient would set the scale: show the settled errors
            span = np.abs(error[settled][:, columns]).max()
            ax.set_ylim(-1.2 * span, 1.2 * span)
    for i, ax in enumerate(axes):
        _mark(ax, data, labelled=i == 0)
        ax.grid(True)
        ax.legend(fontsize=7, loc="upper right")
    axes[0].set_title(_title(data, frame, "attitude (flown − commanded below)", "attitude"), fontsize=9)
    axes[-1].set_xlabel("mission time (s)")
    return _save(fig, out / _name(data, frame, "attitude"))


def _two_curves(data: RunData, out: Path, frame: Frame, key: str, title: str, ylabel: str,
                truth: tuple[np.ndarray, np.ndarray, str], board: tuple[np.ndarray, np.ndarray, str]) -> Path:
    fig, ax = plt.subplots(figsize=(7, 3))
    ax.plot(truth[0], truth[1], "b-", label=truth[2])
    ax.plot(board[0], board[1], "r--", label=board[2])
    _mark(ax, data, labelled=True)
    ax.set_xlabel("mission time (s)")
    ax.set_ylabel(ylabel)
    ax.set_title(_title(data, frame, title, key), fontsize=8)
    ax.legend(fontsize=7)
    ax.grid(True)
    return _save(fig, out / _name(data, frame, key))


def figure_thrust(data: RunData, out: Path, frame: Frame = NED_FRAME) -> Path | None:
    if "thrust_n" not in data.estimates:
        return None
    return _two_curves(data, out, frame, "thrust", "total thrust u1", "thrust (N)",
                       (data.t, data.mass * G, "weight m·g"), (data.est_t, data.estimates["thrust_n"], "u1 (board)"))


def figure_mass(data: RunData, out: Path, frame: Frame = NED_FRAME) -> Path | None:
    if "m_hat" not in data.estimates:
        return None
    return _two_curves(data, out, frame, "mass_estimate", "mass estimate", "mass (kg)",
                       (data.t, data.mass, "true mass"), (data.est_t, data.estimates["m_hat"], r"$\hat{m}$"))


def figure_disturbance(data: RunData, out: Path, frame: Frame = NED_FRAME) -> Path | None:
    keys = ("d_hat_x", "d_hat_y", "d_hat_z")
    if not all(k in data.estimates for k in keys):
        return None
    estimate = frame.position(np.column_stack([data.estimates[k] for k in keys]))
    applied = frame.position(data.force)

    def draw(ax: plt.Axes, i: int) -> None:
        ax.plot(data.t, applied[:, i], "b-", label="applied d_s")
        ax.plot(data.est_t, estimate[:, i], "r--", label=r"$\hat{d}_s$")

    return _per_axis(data, out, frame, "disturbance_estimate", "disturbance estimate", "{axis} (N)", draw)


def report(run_dir: Path, paper_frame: bool = False) -> list[Path]:
    """The figures of a run in report/ (NED) or report/paper_frame/ (the paper's frame and numbering)."""
    data = load_run(run_dir)
    frame = PAPER_FRAME if paper_frame else NED_FRAME
    out = run_dir / "report" / ("paper_frame" if paper_frame else "")
    out.mkdir(parents=True, exist_ok=True)
    builders = (figure_trajectory, figure_errors, figure_attitude, figure_thrust, figure_mass, figure_disturbance)
    figures = [build(data, out, frame) for build in builders]
    return [f for f in figures if f is not None]


def overlay_errors(runs: dict[str, RunData], out: Path, settle_s: float, title: str = "position error by controller",
                   name: str = "overlay_position_error.png", shaded: tuple[tuple[float, float], ...] = (),
                   frame: Frame = NED_FRAME) -> Path:
    """The position errors of several runs on one figure, z on a symlog axis (linear within ±5 cm) so that a
    few centimetres show beside metres; `shaded` marks (start, end) mission-time spans."""
    fig, axes = plt.subplots(3, 1, figsize=(8, 7), sharex=True)
    for label, data in runs.items():
        for i, ax in enumerate(axes):
            ax.plot(data.t, frame.position(data.error)[:, i], label=label, linewidth=1)
    first = next(iter(runs.values()), None)
    for i, ax in enumerate(axes):
        ax.set_ylabel(f"e {frame.axes[i]} (m)")
        ax.axvline(settle_s, color="grey", linestyle=":")
        if first is not None:
            for t in payload_steps(first):
                ax.axvline(t, color="tab:purple", linewidth=1)
        for start, end in shaded:
            ax.axvspan(start, end, color="orange", alpha=0.15)
        ax.grid(True)
    axes[2].set_yscale("symlog", linthresh=Z_LINEAR_BELOW_M)
    low, high = axes[2].get_ylim()
    axes[2].set_yticks([v for m in (0.05, 0.3, 1.0, 3.0) for v in (-m, m) if low <= v <= high] + [0.0])  # sparse
    axes[2].set_ylim(low, high)
    axes[2].yaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
    axes[2].yaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    axes[0].legend(fontsize=8)
    axes[0].set_title(f"{title}, {frame.name}", fontsize=10)
    axes[-1].set_xlabel("mission time (s)")
    return _save(fig, out / name)
