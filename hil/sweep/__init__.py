"""`hil sweep SWEEP.yaml`: Monte Carlo and parameter sweeps through the whole chain, on Dask.

From Python:

    from hil.sweep import run_sweep
    outcome = run_sweep(Path("sweeps/gust_monte_carlo.yaml"), Path("runs/sweep"), jobs=2)
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml
from pydantic import ValidationError

from hil.scenario.loader import load_scenario
from hil.scenario.schema import Scenario
from hil.sweep import results
from hil.sweep.design import Sample, samples, scenario_data
from hil.sweep.execute import (
    RESULT,
    SampleTask,
    finished_results,
    run_command,
    run_tasks,
    sample_dir,
)
from hil.sweep.spec import SweepSpec

__all__ = ["SweepError", "SweepOutcome", "load_sweep", "run_spec", "run_sweep"]


class SweepError(ValueError):
    """The sweep file or its base scenario cannot be used (one line per problem)."""


@dataclass
class SweepOutcome:
    rows: list[dict[str, Any]]
    total: int  # samples the sweep has (after --limit)
    interrupted: bool
    out: Path
    varied: list[str] = field(default_factory=list)


def load_sweep(path: Path) -> SweepSpec:
    try:
        data = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError, UnicodeDecodeError) as exc:
        raise SweepError(f"{path}: {str(exc).splitlines()[0]}") from exc
    if not isinstance(data, dict):
        raise SweepError(f"{path}: expected a mapping of sweep fields")
    try:
        spec = SweepSpec.model_validate(data)
    except ValidationError as exc:
        problems = [f"{path}: {'.'.join(str(p) for p in e['loc']) or '(top)'}: {e['msg']}" for e in exc.errors()]
        raise SweepError("\n".join(problems[:20])) from exc
    scenario = spec.scenario if spec.scenario.is_absolute() else (path.parent / spec.scenario)
    return spec.model_copy(update={"scenario": scenario.resolve()})


def _task(spec: SweepSpec, base: dict[str, Any], sample: Sample, out: Path) -> SampleTask | dict[str, Any]:
    """The sample's task, or (if the sample's scenario is not valid) its result as a failure."""
    try:
        data = scenario_data(base, spec, sample)
        Scenario.model_validate(data)
    except (KeyError, ValidationError) as exc:
        reason = str(exc).splitlines()[0] if isinstance(exc, KeyError) else "; ".join(
            f"{'.'.join(str(p) for p in e['loc'])}: {e['msg']}" for e in exc.errors()[:3])
        return {"index": sample.index, "exit_code": 2, "reason": f"invalid sample: {reason}", "wall_s": 0.0,
                "run_dir": "", "metrics": {}}
    text = yaml.safe_dump({**data, "name": f"{data.get('name', spec.name)}-s{sample.index:05d}"}, sort_keys=False)
    return SampleTask(sample.index, text, str(sample_dir(out, sample.index)))


def run_spec(spec: SweepSpec, out: Path, jobs: int = 2, cluster: str | None = None, limit: int | None = None,
             resume: bool = False, on_progress: Callable[[int, int], None] | None = None) -> SweepOutcome:
    """Fly the sweep's samples (the first `limit`), skipping those finished before when resuming, and
    write sweep.parquet and sweep.md; Ctrl-C keeps what finished and writes a partial summary."""
    load_scenario(spec.scenario)  # the base must be valid on its own
    base = yaml.safe_load(spec.scenario.read_text())
    out = out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    plan = samples(spec)[:limit]
    done = finished_results(out) if resume else {}
    todo = [_task(spec, base, s, out) for s in plan if s.index not in done]
    for result in (t for t in todo if isinstance(t, dict)):
        done[result["index"]] = result
        sample_dir(out, result["index"]).mkdir(parents=True, exist_ok=True)
        (sample_dir(out, result["index"]) / RESULT).write_text(json.dumps(result))
    tasks = [t for t in todo if isinstance(t, SampleTask)]

    def finished(result: dict[str, Any]) -> None:
        done[result["index"]] = result
        if on_progress:
            on_progress(len(done), len(plan))

    if on_progress:
        on_progress(len(done), len(plan))
    interrupted = False
    started = time.monotonic()
    try:
        run_tasks(tasks, out, jobs, cluster, finished)
    except KeyboardInterrupt:
        interrupted = True
    varied = list(spec.vary) + list(spec.cross)
    rows = [results.make_row(s.values, done[s.index], run_command(sample_dir(out, s.index)))
            for s in plan if s.index in done]
    _write(spec, out, rows, len(plan), varied, interrupted, time.monotonic() - started, jobs, cluster)
    return SweepOutcome(rows, len(plan), interrupted, out, varied)


def run_sweep(path: Path, out: Path, **options: Any) -> SweepOutcome:
    return run_spec(load_sweep(path), out, **options)


def _write(spec: SweepSpec, out: Path, rows: list[dict[str, Any]], total: int, varied: list[str],
           interrupted: bool, wall_s: float, jobs: int, cluster: str | None) -> None:
    results.write_parquet(rows, out / "sweep.parquet")
    group_by = "board.controller" if "board.controller" in varied else None
    where = f"the Dask cluster at {cluster}" if cluster else f"a LocalCluster of {jobs} worker(s)"
    header = [f"Base scenario `{spec.scenario.name}`, {spec.design} design, {len(rows)} of {total} samples "
              f"finished{' (interrupted: partial results; `--resume` continues)' if interrupted else ''}, on "
              f"{where}: {sum(r['wall_s'] for r in rows):.0f} s of flights in all, {wall_s:.0f} s elapsed in this "
              "invocation.",
              f"Varied: {', '.join(f'`{v}`' for v in varied) or 'nothing'}. Each sample is a full `hil run` through "
              "the chain; its run directory is under `samples/`."]
    figures = results.figures(rows, varied, group_by, out) if rows else []
    (out / "sweep.md").write_text(results.markdown(spec.name, header, rows, varied, group_by, figures))
