"""`hil sweep SWEEP.yaml`: Monte Carlo and parameter sweeps through the whole chain, on Dask.

From Python:

    from hil.sweep import run_sweep
    outcome = run_sweep(Path("sweeps/gust_monte_carlo.yaml"), Path("runs/sweep"), jobs=2)
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from contextlib import nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml
from pydantic import ValidationError

from hil.scenario.loader import ScenarioError, YamlPath, load_scenario, located_problems, read_yaml
from hil.sweep import results
from hil.sweep.check import Invalid, sweep_problems, validate_samples
from hil.sweep.design import Sample, samples
from hil.sweep.execute import (
    RESULT,
    ClusterUnreachable,
    SampleTask,
    dask_client,
    finished_results,
    run_command,
    run_tasks,
    sample_dir,
)
from hil.sweep.options import option_problems
from hil.sweep.spec import SweepSpec

__all__ = ["ClusterUnreachable", "SweepError", "SweepOutcome", "load_sweep", "run_spec", "run_sweep",
           "sample_scenarios"]

SECTIONS = ("overrides", "vary", "cross")  # the sweep's keys that name scenario fields


class SweepError(ValueError):
    """The sweep file, its samples or its options cannot be used: one line per problem, at most 20."""

    def __init__(self, lines: list[str]) -> None:
        super().__init__("\n".join(lines))
        self.lines = lines

    @classmethod
    def of(cls, error: ScenarioError) -> SweepError:
        return cls([str(p) for p in error.problems])


@dataclass
class SweepOutcome:
    rows: list[dict[str, Any]]
    total: int  # samples the sweep has (after --limit)
    interrupted: bool
    out: Path
    varied: list[str] = field(default_factory=list)


def _key_lines(index: dict[YamlPath, yaml.Node]) -> dict[str, int]:
    """"vary.seed" -> the line of that key in the sweep file."""
    return {f"{where[0]}.{where[1]}": node.start_mark.line + 1 for where, node in index.items()
            if len(where) == 2 and where[0] in SECTIONS}


def load_sweep(path: Path) -> SweepSpec:
    """The validated sweep file (read within the scenario loader's bounds), or SweepError."""
    path = Path(path)
    try:
        index, data = read_yaml(path)
        if not isinstance(data, dict):
            raise SweepError([f"{path}: expected a mapping of sweep fields, found "
                              f"{'an empty file' if data is None else type(data).__name__}"])
        try:
            spec = SweepSpec.model_validate(data)
        except ValidationError as exc:
            raise ScenarioError(located_problems(path, index, exc)) from None
    except ScenarioError as exc:
        raise SweepError.of(exc) from None
    scenario = spec.scenario if spec.scenario.is_absolute() else (path.parent / spec.scenario)
    if not scenario.is_file():
        where = index[("scenario",)].start_mark.line + 1
        raise SweepError([f"{path}:{where}: scenario: no such file: {scenario} (a path relative to the sweep file)"])
    return spec.model_copy(update={"scenario": scenario.resolve()}).from_file(path, _key_lines(index))


def _base(spec: SweepSpec) -> dict[str, Any]:
    """The base scenario's plain data, validated on its own first (ScenarioError names its file)."""
    load_scenario(spec.scenario)
    return read_yaml(spec.scenario)[1]


def sample_scenarios(spec: SweepSpec, plan: list[Sample]) -> tuple[dict[int, dict[str, Any]], dict[int, list[Invalid]]]:
    """Each valid sample's scenario data by index, named `<base>-sNNNNN` as its run directory and results row are,
    and each invalid sample's reasons: what `hil sweep` flies and what the pytest plugin collects. SweepError when
    the sweep file itself is wrong, ScenarioError when its base scenario is."""
    valid, invalid = validate_samples(_base(spec), spec, plan)
    problems = sweep_problems(spec, plan, invalid)
    if problems:
        raise SweepError.of(ScenarioError(problems))
    return {i: {**data, "name": f"{data.get('name', spec.name)}-s{i:05d}"} for i, data in valid.items()}, invalid


def _tasks(spec: SweepSpec, plan: list[Sample], done: dict[int, dict[str, Any]],
           out: Path) -> tuple[list[SampleTask], list[dict[str, Any]]]:
    """What to fly, and the results of the invalid samples; SweepError when the sweep file itself is wrong."""
    named, invalid = sample_scenarios(spec, [s for s in plan if s.index not in done])
    tasks = [SampleTask(i, yaml.safe_dump(data, sort_keys=False), str(sample_dir(out, i))) for i, data in named.items()]
    failures = [{"index": i, "exit_code": 2, "reason": f"invalid sample: {'; '.join(r.reason for r in reasons[:3])}",
                 "wall_s": 0.0, "run_dir": "", "metrics": {}} for i, reasons in invalid.items()]
    return tasks, failures


def _make_out(out: Path) -> None:
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SweepError([f"--out {out}: cannot create it: {exc.strerror or exc}"]) from None


def run_spec(spec: SweepSpec, out: Path, jobs: int = 2, cluster: str | None = None, limit: int | None = None,
             resume: bool = False, on_progress: Callable[[int, int], None] | None = None) -> SweepOutcome:
    """Fly the sweep's samples (the first `limit`), skipping those finished before when resuming, and
    write sweep.parquet and sweep.md; Ctrl-C keeps what finished and writes a partial summary. Everything
    is checked before anything starts or is written: SweepError (bad input), ScenarioError (the base
    scenario), ClusterUnreachable (no scheduler at `cluster`)."""
    out = out.resolve()
    problems = option_problems(jobs, limit, cluster, out, resume)
    if problems:
        raise SweepError(problems)
    plan = samples(spec)[:limit]
    done = finished_results(out) if resume else {}
    tasks, failures = _tasks(spec, plan, done, out)
    interrupted = False
    started = time.monotonic()
    try:
        with dask_client(jobs, cluster) if tasks else nullcontext() as client:
            _make_out(out)
            for result in failures:
                done[result["index"]] = result
                sample_dir(out, result["index"]).mkdir(parents=True, exist_ok=True)
                (sample_dir(out, result["index"]) / RESULT).write_text(json.dumps(result))
            _fly(client, tasks, out, done, len(plan), on_progress)
    except KeyboardInterrupt:
        interrupted = True
    varied = list(spec.vary) + list(spec.cross)
    rows = [results.make_row(s.values, done[s.index], run_command(sample_dir(out, s.index)))
            for s in plan if s.index in done]
    if out.is_dir():  # not when stopped before anything started
        _write(spec, out, rows, len(plan), varied, interrupted, time.monotonic() - started, jobs, cluster)
    return SweepOutcome(rows, len(plan), interrupted, out, varied)


def _fly(client: Any, tasks: list[SampleTask], out: Path, done: dict[int, dict[str, Any]], total: int,
         on_progress: Callable[[int, int], None] | None) -> None:
    def finished(result: dict[str, Any]) -> None:
        done[result["index"]] = result
        if on_progress:
            on_progress(len(done), total)

    if on_progress:
        on_progress(len(done), total)
    if tasks:
        run_tasks(client, tasks, out, finished)


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
