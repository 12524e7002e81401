"""A sweep's results: `sweep.parquet` (one row per sample), `sweep.md` and its figures."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

# metrics that measure this machine, not the flight: they differ between two runs of the same sample
WALL_CLOCK_METRICS = ("timing.", "link.", "gcs.")
TRACKING = tuple(f"position_error_m.{a}.{s}" for s in ("max_abs", "rms") for a in "xyz") + tuple(
    f"attitude_error_deg.{a}.max_abs" for a in ("roll", "pitch", "yaw"))
HEADLINE = "max_abs_error_m"  # the largest |e| of the three axes: what a sample is ranked by
PERCENTILES = (50, 90, 99)
WORST = 5


def flatten(tree: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested metrics as dotted columns; lists of scalars stay lists, lists of mappings are indexed."""
    flat: dict[str, Any] = {}
    for key, value in tree.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            flat.update(flatten(value, name + "."))
        elif isinstance(value, list) and value and isinstance(value[0], dict):
            for i, item in enumerate(value):
                flat.update(flatten(item, f"{name}[{i}]."))
        else:
            flat[name] = value
    return flat


BOOKKEEPING = ("sample", "exit_code", "reason", "wall_s", "run_dir", "command")


def flight_metrics(row: dict[str, Any], varied: list[str]) -> dict[str, Any]:
    """The row's metrics that describe the flight (same seed -> same values): no varied value, no
    bookkeeping, no wall-clock measurement, no column that only other rows have (None in the parquet)."""
    return {k: v for k, v in row.items()
            if v is not None and k not in BOOKKEEPING and k not in varied and not k.startswith(WALL_CLOCK_METRICS)}


def make_row(values: dict[str, Any], result: dict[str, Any], command: list[str]) -> dict[str, Any]:
    metrics = flatten(result.get("metrics", {}))
    for key in ("exit_code", "reason"):
        metrics.pop(key, None)
    axes = [metrics.get(f"position_error_m.{a}.max_abs") for a in "xyz"]
    numbers = [a for a in axes if isinstance(a, (int, float))]
    headline = max(numbers) if len(numbers) == len(axes) else None
    return {"sample": result["index"], **values, "exit_code": result["exit_code"], "reason": result["reason"],
            "wall_s": result["wall_s"], "run_dir": result["run_dir"], "command": " ".join(command),
            HEADLINE: headline, **metrics}


def write_parquet(rows: list[dict[str, Any]], path: Path) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    columns: dict[str, None] = {}
    for row in rows:
        columns.update(dict.fromkeys(row))
    table = pa.Table.from_pylist([{c: row.get(c) for c in columns} for row in rows])
    pq.write_table(table, path)


def read_parquet(path: Path) -> list[dict[str, Any]]:
    import pyarrow.parquet as pq

    return pq.read_table(path).to_pylist()


def _group(row: dict[str, Any], group_by: str | None) -> str:
    return str(row.get(group_by, "all")) if group_by else "all"


def _percentile_table(rows: list[dict[str, Any]], group_by: str | None) -> list[str]:
    lines = ["| metric | group | flown | p50 | p90 | p99 | max |", "| --- | --- | --- | --- | --- | --- | --- |"]
    groups = sorted({_group(r, group_by) for r in rows})
    for metric in (HEADLINE, *TRACKING):
        for group in groups:
            values = [r[metric] for r in rows
                      if _group(r, group_by) == group and isinstance(r.get(metric), (int, float))]
            if values:
                cells = " | ".join(f"{np.percentile(values, p):.3f}" for p in PERCENTILES)
                lines.append(f"| {metric} | {group} | {len(values)} | {cells} | {max(values):.3f} |")
    return lines


def _pass_rates(rows: list[dict[str, Any]], group_by: str | None) -> list[str]:
    lines = ["| group | samples | pass (exit 0) | expectations not met (exit 1) | failed to fly |",
             "| --- | --- | --- | --- | --- |"]
    for group in sorted({_group(r, group_by) for r in rows}):
        members = [r for r in rows if _group(r, group_by) == group]
        passed = sum(r["exit_code"] == 0 for r in members)
        missed = sum(r["exit_code"] == 1 for r in members)
        lines.append(f"| {group} | {len(members)} | {passed} ({100 * passed / len(members):.0f} %) | {missed} | "
                     f"{len(members) - passed - missed} |")
    return lines


def _severity(row: dict[str, Any]) -> float:
    """Failed samples first, then by the largest position error."""
    value = row.get(HEADLINE)
    return math.inf if row["exit_code"] not in (0, 1) or not isinstance(value, (int, float)) else float(value)


def _worst(rows: list[dict[str, Any]], varied: list[str]) -> list[str]:
    lines = ["| sample | " + " | ".join(varied) + " | exit | max \\|e\\| (m) | reason | replay |",
             "| --- | " + " | ".join("---" for _ in varied) + " | --- | --- | --- | --- |"]
    for row in sorted(rows, key=_severity, reverse=True)[:WORST]:
        cells = " | ".join(_short(row.get(v)) for v in varied)
        headline = row.get(HEADLINE)
        lines.append(f"| {row['sample']} | {cells} | {row['exit_code']} | "
                     f"{'–' if headline is None else f'{headline:.3f}'} | {row['reason'][:80]} | `{row['command']}` |")
    return lines


def _short(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.3g}"
    if isinstance(value, list):
        return "[" + ", ".join(_short(v) for v in value) + "]"
    return str(value)


def markdown(title: str, header: list[str], rows: list[dict[str, Any]], varied: list[str],
             group_by: str | None, figures: list[Path]) -> str:
    lines = [f"# Sweep: {title}", "", *header, "", "## Pass rate against the scenario's `expect`", "",
             *_pass_rates(rows, group_by), "", "## Tracking error percentiles (m, deg)", "",
             *_percentile_table(rows, group_by), "", f"## The {WORST} worst samples", "",
             "Failed samples first, then by the largest position error; `replay` flies the sample alone.", "",
             *_worst(rows, varied)]
    if figures:
        lines += ["", "## Figures", ""] + [f"![{f.stem}]({f.name})" for f in figures]
    return "\n".join(lines) + "\n"


def _numeric(value: Any) -> float | None:
    """A varied value as one number for a sensitivity plot (a vector by its horizontal magnitude)."""
    if isinstance(value, bool) or value is None:
        return None
    if isinstance(value, (int, float)):
        return float(value)
    if isinstance(value, list) and len(value) >= 2 and all(isinstance(v, (int, float)) for v in value):
        return float(math.hypot(value[0], value[1]))
    return None


def figures(rows: list[dict[str, Any]], varied: list[str], group_by: str | None, out: Path) -> list[Path]:
    """The sensitivity view: the headline metric against each numeric varied parameter, per group (a seed
    is a name for a random stream, not a quantity: it gets no axis)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    numeric = [v for v in varied if v not in (group_by, "seed") and any(_numeric(r.get(v)) is not None for r in rows)]
    if not numeric:
        return []
    fig, axes = plt.subplots(1, len(numeric), figsize=(4.2 * len(numeric), 3.6), squeeze=False)
    for ax, parameter in zip(axes[0], numeric, strict=True):
        for group in sorted({_group(r, group_by) for r in rows}):
            points = [(_numeric(r.get(parameter)), r.get(HEADLINE)) for r in rows if _group(r, group_by) == group]
            points = [(x, y) for x, y in points if x is not None and isinstance(y, (int, float))]
            if points:
                ax.scatter(*zip(*points, strict=True), s=14, label=group, alpha=0.8)
        ax.set_xlabel(parameter + (" (|horizontal|)" if any(isinstance(r.get(parameter), list) for r in rows) else ""))
        ax.set_ylabel("max |e| over x, y, z (m)")
        ax.grid(True)
    axes[0][0].legend(fontsize=8)
    fig.tight_layout()
    path = out / "sweep_sensitivity.png"
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return [path]
