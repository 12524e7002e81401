"""Writes docs/foxglove_layout.json, the bench's Foxglove layout, with foxglove-sdk's layout types.

Run: .venv/bin/python docs/foxglove/make_layout.py   (Foxglove: Layouts → Import from file)
Tabs: 3D view and map; position vs reference; attitude vs commanded; motors; the controller's m̂ and d̂.
"""

from __future__ import annotations

from pathlib import Path

import foxglove.layouts as fl

OUT = Path(__file__).resolve().parent.parent / "foxglove_layout.json"
AXES = ("x", "y", "z")


def path(topic: str, field: str) -> str:
    """A Foxglove message path; the topic is quoted because it contains slashes."""
    return f'"{topic}".{field}'


def plot(title: str, series: list[tuple[str, str]]) -> fl.PlotPanel:
    """A plot of (message path, label) pairs against time."""
    return fl.PlotPanel(title=title, config=fl.PlotConfig(
        paths=[fl.PlotSeries(value=path, label=label, enabled=True) for path, label in series],
        show_legend=True, is_synced=True, x_axis_val="timestamp"))


def tracking(quantity: str, reference_path: str, flown_path: str, unit: str) -> fl.PlotPanel:
    series = []
    for i, axis in enumerate(("N", "E", "D")):
        series += [(f"{reference_path}[{i}]", f"reference {axis}"), (f"{flown_path}[{i}]", f"flown {axis}")]
    return plot(f"{quantity} ({unit})", series)


def attitude_series() -> list[tuple[str, str]]:
    series = []
    for i, angle in enumerate(("roll", "pitch", "yaw")):
        series += [(path("hil/board/attitude_target", f"rpy[{i}]"), f"commanded {angle}"),
                   (path("hil/state", f"rpy[{i}]"), f"flown {angle}")]
    return series


def tab(title: str, *panels: object) -> fl.TabItem:
    items = [fl.SplitItem(content=p) for p in panels]  # type: ignore[arg-type]
    return fl.TabItem(title=title, content=fl.SplitContainer(direction="column", items=items))


def layout() -> fl.Layout:
    view = fl.SplitContainer(direction="row", items=[
        fl.SplitItem(content=fl.ThreeDeePanel(title="3D (display frame enu)", config=fl.ThreeDeeConfig(
            follow_tf="vehicle", fixed_frame="enu", follow_mode="follow-position"))),
        fl.SplitItem(content=fl.MapPanel(title="map", config=fl.MapConfig(follow_topic="foxglove/truth_fix"))),
    ])
    estimates = [(path("hil/board/estimates", f"values.d_hat_{a}"), f"d̂ {a} (N)") for a in AXES]
    return fl.Layout(content=fl.TabContainer(tabs=[
        fl.TabItem(title="3D and map", content=view),
        tab("position", tracking("position", path("hil/reference", "pos_ned"), path("hil/state", "pos_ned"), "m")),
        tab("attitude", plot("attitude vs commanded (rad)",
                             attitude_series()),
            plot("thrust", [(path("hil/board/attitude_target", "thrust"), "commanded thrust (0..1)")])),
        tab("motors", plot("motor commands (0..1)",
                           [(path("hil/actuators", f"motors[{i}]"), f"motor {i + 1}") for i in range(4)])),
        tab("estimates", plot("mass: m̂ vs true (kg)", [(path("hil/board/estimates", "values.m_hat"), "m̂"),
                                                     (path("hil/state", "total_mass"), "true mass")]),
            plot("disturbance estimate", estimates)),
    ]))


if __name__ == "__main__":
    OUT.write_text(layout().to_json() + "\n")
    print(f"written: {OUT}")
