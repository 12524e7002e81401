"""`hil sweep`, `hil compare`: many flights."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from hil.app.arguments import load_scenarios
from hil.exit_codes import EXIT_BAD_INPUT, EXIT_BOARD, EXIT_INTERRUPTED, EXIT_OK


def _cmd_sweep(args: argparse.Namespace) -> int:
    from hil.app.progress import sample_progress
    from hil.scenario.loader import ScenarioError
    from hil.sweep import ClusterUnreachable, SweepError, load_sweep, run_spec

    try:
        spec = load_sweep(Path(args.sweep))
        out = Path(args.out) if args.out else Path("runs") / f"sweep-{spec.name}"
        with sample_progress(spec.name) as progress:
            outcome = run_spec(spec, out, jobs=args.jobs, cluster=args.cluster, limit=args.limit, resume=args.resume,
                               on_progress=progress)
    except (SweepError, ScenarioError, ClusterUnreachable) as exc:
        for line in str(exc).splitlines():
            print(f"hil sweep: {line}" if line.startswith("--") else line, file=sys.stderr)  # an option, or a file
        return EXIT_BOARD if isinstance(exc, ClusterUnreachable) else EXIT_BAD_INPUT
    failed = sum(r["exit_code"] not in (0, 1) for r in outcome.rows)
    print(f"{len(outcome.rows)} of {outcome.total} samples finished ({failed} failed to fly)"
          f"{'; interrupted: hil sweep --resume continues' if outcome.interrupted else ''}")
    print(f"written: {outcome.out / 'sweep.parquet'}, {outcome.out / 'sweep.md'}")
    return EXIT_INTERRUPTED if outcome.interrupted else EXIT_OK


def _cmd_compare(args: argparse.Namespace) -> int:
    from hil.app.compare import compare
    from hil.app.input_checks import compare_problems

    scenarios, bad = load_scenarios([args.scenario])
    if bad:
        return EXIT_BAD_INPUT
    scenario = scenarios[0][1]
    controllers = [c.strip() for c in args.controllers.split(",") if c.strip()]
    out = Path(args.out) if args.out else Path("runs") / f"compare-{scenario.name}"
    problems = compare_problems(args, controllers, out)
    for problem in problems:
        print(f"hil compare: {problem}", file=sys.stderr)
    if problems:
        return EXIT_BAD_INPUT
    seeds = [scenario.seed + i for i in range(args.seeds)]
    result, markdown = compare(Path(args.scenario), scenario, controllers, seeds, args.jobs, out)
    print(markdown, end="")
    print(f"written: {out / 'comparison.md'}, {out / 'comparison.json'}, plots under {out}")
    return EXIT_OK if all(r["exit_code"] in (0, 1) for r in result["runs"]) else EXIT_BOARD


def add_study_commands(sub: argparse._SubParsersAction) -> None:
    """`hil sweep`, `hil compare`: many flights."""
    sweep = sub.add_parser("sweep", help="Monte Carlo / parameter sweep of a scenario, on Dask (hil sweep SWEEP.yaml)")
    sweep.add_argument("sweep", help="sweep YAML file (see sweeps/)")
    sweep.add_argument("--jobs", type=int, default=2, help="LocalCluster worker processes (one run each at a time)")
    sweep.add_argument("--cluster", metavar="ADDRESS", help="an existing Dask scheduler, e.g. tcp://10.0.0.5:8786")
    sweep.add_argument("--limit", type=int, help="fly only the first N samples")
    sweep.add_argument("--resume", action="store_true", help="continue a stopped sweep in --out")
    sweep.add_argument("--out", help="results directory (default runs/sweep-<name>)")
    sweep.set_defaults(func=_cmd_sweep)
    compare = sub.add_parser("compare", help="fly a scenario with several controllers and compare (Tables 1-2)")
    compare.add_argument("scenario")
    compare.add_argument("--controllers", default="smarc,smpid,backstepping")
    compare.add_argument("--seeds", type=int, default=1, help="seeds per controller, from the scenario's seed up")
    compare.add_argument("--jobs", type=int, default=2, help="flights in parallel (each is two processes)")
    compare.add_argument("--out", help="output directory (default runs/compare-<scenario>)")
    compare.set_defaults(func=_cmd_compare)
