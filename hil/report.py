"""`hil report RUN_DIR`: PNG figures like the paper's Figures 5–10, and overlays for comparisons.

matplotlib is imported here only (never in the loop), with the non-interactive Agg backend.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from hil.rundata import RunData, load_run  # noqa: E402

AXES = ("x (north)", "y (east)", "z (down)")
ANGLES = ("roll γ", "pitch θ", "yaw ψ")


def _save(fig: plt.Figure, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def figure_trajectory(data: RunData, out: Path) -> Path:
    fig = plt.figure(figsize=(6, 5))
    ax = fig.add_subplot(projection="3d")
    ax.plot(data.ref[:, 0], data.ref[:, 1], -data.ref[:, 2], "b-", label="reference")
    ax.plot(data.pos[:, 0], data.pos[:, 1], -data.pos[:, 2], "r--", label="flown")
    ax.set_xlabel("north (m)")
    ax.set_ylabel("east (m)")
    ax.set_zlabel("height (m)")
    ax.set_title(f"{data.name}, {data.controller}: trajectory (cf. Fig. 5)")
    ax.legend()
    return _save(fig, out / "fig5_trajectory.png")


def figure_errors(data: RunData, out: Path) -> Path:
    fig, axes = plt.subplots(3, 1, figsize=(7, 6), sharex=True)
    for i, ax in enumerate(axes):
        ax.plot(data.t, data.error[:, i], "r-")
        ax.set_ylabel(f"e {AXES[i]} (m)")
        ax.grid(True)
    axes[0].set_title(f"{data.name}, {data.controller}: position error (cf. Fig. 6)")
    axes[-1].set_xlabel("mission time (s)")
    return _save(fig, out / "fig6_position_error.png")


def _three_rows(data: RunData, out: Path, name: str, title: str, ylabels: list[str],
                reference: tuple[np.ndarray, np.ndarray, str], flown: tuple[np.ndarray, np.ndarray, str]) -> Path:
    """Three stacked axes, a reference (blue) against what was flown or estimated (red dashed)."""
    fig, axes = plt.subplots(3, 1, figsize=(7, 6), sharex=True)
    for i, ax in enumerate(axes):
        if len(reference[0]):
            ax.plot(reference[0], reference[1][:, i], "b-", label=reference[2])
        ax.plot(flown[0], flown[1][:, i], "r--", label=flown[2])
        ax.set_ylabel(ylabels[i])
        ax.grid(True)
    axes[0].legend()
    axes[0].set_title(f"{data.name}, {data.controller}: {title}")
    axes[-1].set_xlabel("mission time (s)")
    return _save(fig, out / name)


def figure_attitude(data: RunData, out: Path) -> Path:
    return _three_rows(data, out, "fig7_attitude.png", "attitude (cf. Fig. 7)", [f"{a} (deg)" for a in ANGLES],
                       (data.cmd_t, np.degrees(data.cmd_rpy), "commanded"), (data.t, np.degrees(data.rpy), "flown"))


def _two_curves(data: RunData, out: Path, name: str, title: str, ylabel: str,
                truth: tuple[np.ndarray, np.ndarray, str], board: tuple[np.ndarray, np.ndarray, str]) -> Path:
    fig, ax = plt.subplots(figsize=(7, 3))
    ax.plot(truth[0], truth[1], "b-", label=truth[2])
    ax.plot(board[0], board[1], "r--", label=board[2])
    ax.set_xlabel("mission time (s)")
    ax.set_ylabel(ylabel)
    ax.set_title(f"{data.name}, {data.controller}: {title}")
    ax.legend()
    ax.grid(True)
    return _save(fig, out / name)


def figure_thrust(data: RunData, out: Path) -> Path | None:
    if "thrust_n" not in data.estimates:
        return None
    return _two_curves(data, out, "fig8_thrust.png", "total thrust u1 (cf. Fig. 8)", "thrust (N)",
                       (data.t, data.mass * 9.80665, "weight m·g"), (data.est_t, data.estimates["thrust_n"], "u1 (board)"))


def figure_mass(data: RunData, out: Path) -> Path | None:
    if "m_hat" not in data.estimates:
        return None
    return _two_curves(data, out, "fig9_mass_estimate.png", "mass estimate (cf. Fig. 9)", "mass (kg)",
                       (data.t, data.mass, "true mass"), (data.est_t, data.estimates["m_hat"], "m̂"))


def figure_disturbance(data: RunData, out: Path) -> Path | None:
    keys = ("d_hat_x", "d_hat_y", "d_hat_z")
    if not all(k in data.estimates for k in keys):
        return None
    estimate = np.column_stack([data.estimates[k] for k in keys])
    return _three_rows(data, out, "fig10_disturbance_estimate.png", "disturbance estimate (cf. Fig. 10)",
                       [f"{a} (N)" for a in AXES], (data.t, data.force, "applied d_s"), (data.est_t, estimate, "d̂_s"))


def report(run_dir: Path) -> list[Path]:
    data = load_run(run_dir)
    out = run_dir / "report"
    out.mkdir(exist_ok=True)
    figures = [figure_trajectory(data, out), figure_errors(data, out), figure_attitude(data, out),
               figure_thrust(data, out), figure_mass(data, out), figure_disturbance(data, out)]
    return [f for f in figures if f is not None]


def overlay_errors(runs: dict[str, RunData], out: Path, settle_s: float, title: str = "position error by controller",
                   name: str = "overlay_position_error.png",
                   shaded: tuple[tuple[float, float], ...] = ()) -> Path:
    """The position errors of several runs on one figure; `shaded` marks (start, end) mission-time spans."""
    fig, axes = plt.subplots(3, 1, figsize=(8, 7), sharex=True)
    for label, data in runs.items():
        for i, ax in enumerate(axes):
            ax.plot(data.t, data.error[:, i], label=label, linewidth=1)
    for i, ax in enumerate(axes):
        ax.set_ylabel(f"e {AXES[i]} (m)")
        ax.axvline(settle_s, color="grey", linestyle=":")
        for start, end in shaded:
            ax.axvspan(start, end, color="orange", alpha=0.15)
        ax.grid(True)
    axes[0].legend(fontsize=8)
    axes[0].set_title(title, fontsize=10)
    axes[-1].set_xlabel("mission time (s)")
    return _save(fig, out / name)
