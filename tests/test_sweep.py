"""`hil sweep`: the design (by hand), the whole chain per sample on a Dask LocalCluster and on a separately
started scheduler with workers, replays of single samples, Ctrl-C with --resume, failed samples."""

from __future__ import annotations

import json
import math
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from hil.sweep import SweepError, load_sweep
from hil.sweep.design import Sample, samples, scenario_data, set_path
from hil.sweep.results import flight_metrics, make_row, read_parquet
from hil.sweep.spec import SweepSpec
from tests.support.ports import free_port

pytestmark = pytest.mark.e2e  # drives the bench's processes (hil, the emulator) end to end

ROOT = Path(__file__).resolve().parent.parent
# the sweeps below fly a 2 s hold 2 m up and disarm where they are: the sweep's bookkeeping is what they check,
# and every second of simulated time is paid by every sample (~7 s of arming and take-off come with each)
TINY_HOVER = ("name: tiny_hover\nduration_s: 2\nseed: 1\nreference: {type: hover, altitude_m: 2}\n"
              "wind: {steady_ned: [1, 0, 0], turbulence: {intensity: light}}\nend: disarm\n"
              "expect: {settle_s: 1, max_error_m: 1.0}\n")


def tiny_hover(folder: Path) -> Path:
    path = folder / "tiny_hover.yaml"
    path.write_text(TINY_HOVER)
    return path


def hil(*args: str, timeout: float = 900) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "hil", *args], capture_output=True, text=True, cwd=ROOT,
                          timeout=timeout)


def tiny_sweep(tmp_path: Path, samples_: int = 3, extra: str = "") -> Path:
    path = tmp_path / "tiny.yaml"
    path.write_text(f"name: tiny\nscenario: {tiny_hover(tmp_path)}\ndesign: random\nsamples: {samples_}\nseed: 5\n"
                    "vary:\n  seed: {integers: [1, 1000]}\n  wind.steady_ned: {polar: {speed: [0, 3]}}\n"
                    f"cross:\n  board.controller: [smarc, smpid]\n{extra}")
    return path


def test_set_path_walks_mappings_and_list_items():
    tree = {"wind": {"gusts": [{"peak_ned": [0, 0, 0]}]}}
    set_path(tree, "wind.gusts[0].peak_ned", [1, 2, 3])
    set_path(tree, "vehicle.mass", 2.0)  # a mapping on the way is created
    set_path(tree, "wind.gusts[0].peak_ned[2]", -1)
    assert tree == {"wind": {"gusts": [{"peak_ned": [1, 2, -1]}]}, "vehicle": {"mass": 2.0}}
    with pytest.raises(KeyError, match=r"payload\[0\]"):
        set_path(tree, "payload[0].mass_kg", 1.0)


def test_random_design_draws_from_its_own_seed_and_crosses_innermost():
    spec = SweepSpec.model_validate({
        "name": "d", "scenario": "x.yaml", "samples": 50, "seed": 3,
        "vary": {"seed": {"integers": [1, 4]}, "wind.gusts[0].peak_ned": {"polar": {"speed": [2, 8]}},
                 "payload[0].mass_kg": {"uniform": [0, 1]},
                 "wind.turbulence.intensity": {"choice": ["light", "moderate"]}},
        "cross": {"board.controller": ["smarc", "smpid", "backstepping"]}})
    plan = samples(spec)
    assert len(plan) == 150 and [s.index for s in plan] == list(range(150))
    assert plan == samples(spec)  # the same sweep seed, the same samples
    for draw in range(50):
        trio = plan[3 * draw:3 * draw + 3]
        assert [s.values["board.controller"] for s in trio] == ["smarc", "smpid", "backstepping"]
        assert trio[0].values["seed"] == trio[1].values["seed"] == trio[2].values["seed"]
    for sample in plan:
        north, east, down = sample.values["wind.gusts[0].peak_ned"]
        assert 2 <= math.hypot(north, east) <= 8 and down == 0
        assert sample.values["seed"] in (1, 2, 3, 4) and 0 <= sample.values["payload[0].mass_kg"] <= 1
    headings = [math.degrees(math.atan2(s.values["wind.gusts[0].peak_ned"][1], s.values["wind.gusts[0].peak_ned"][0]))
                for s in plan[::3]]
    assert min(headings) < -90 and max(headings) > 90  # from any direction
    other = samples(spec.model_copy(update={"seed": 4}))
    assert [s.values for s in other] != [s.values for s in plan]


def test_grid_design_enumerates_every_combination():
    spec = SweepSpec.model_validate({"name": "g", "scenario": "x.yaml", "design": "grid",
                                     "vary": {"vehicle.mass": {"range": {"start": 1, "stop": 2, "num": 3}},
                                              "seed": [1, 2]}, "cross": {"board.controller": ["smarc", "smpid"]}})
    plan = samples(spec)
    assert len(plan) == 3 * 2 * 2
    assert {(s.values["vehicle.mass"], s.values["seed"]) for s in plan} == {
        (m, s) for m in (1.0, 1.5, 2.0) for s in (1, 2)}
    data = scenario_data({"name": "b", "payload": []}, spec, plan[0])
    assert data["vehicle"]["mass"] == 1.0 and data["board"]["controller"] == "smarc"


def test_a_bad_sweep_file_is_one_line_per_problem_and_exit_2(tmp_path):
    grid = tmp_path / "bad.yaml"
    grid.write_text(f"name: bad\nscenario: {tiny_hover(tmp_path)}\ndesign: grid\n"
                    "vary:\n  vehicle.mass: {uniform: [1, 2]}\n")
    with pytest.raises(SweepError, match="grid design enumerates lists and ranges only"):
        load_sweep(grid)
    typo = tmp_path / "typo.yaml"
    typo.write_text(f"name: typo\nscenario: {tiny_hover(tmp_path)}\nvary:\n  seed: {{integer: [1, 2]}}\n")
    result = hil("sweep", str(typo), "--out", str(tmp_path / "out"))
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert "typo.yaml" in result.stderr and "vary.seed" in result.stderr


def _rerun_alone(row: dict, tmp_path: Path) -> dict:
    """Fly one sample again with the command its row gives, and return its flight metrics."""
    command = row["command"].split()
    assert command[:2] == ["hil", "run"]
    runs = tmp_path / f"replay-{row['sample']}"
    result = hil("run", *command[2:], "--runs", str(runs), "--no-telemetry", "--no-gcs", "--no-report")
    assert result.returncode == row["exit_code"], result.stderr
    (run_dir,) = runs.iterdir()
    metrics = json.loads((run_dir / "metrics.json").read_text())
    replayed = make_row({}, {"index": row["sample"], "exit_code": result.returncode, "reason": "", "wall_s": 0.0,
                             "run_dir": "", "metrics": metrics}, [])
    return flight_metrics(replayed, [])


def short_monte_carlo(folder: Path) -> Path:
    """The shipped gust Monte Carlo (its design, draws and crossing unchanged) on a 3 s mission 2 m up, judged
    from 1 s (gust.yaml's 5 s settle time would not fit), the gust at 0.5 s and the payload at 2 s, disarmed
    where it ends instead of landing: every varied value still acts on the flight, and the chain and the
    bookkeeping are what the tests check. 40 full 25 s samples at 12 m take ~8 min of CI, 6 s ones that land
    ~3 min (docs/sweeps.md has the full sweep's figures)."""
    spec = yaml.safe_load((ROOT / "sweeps" / "gust_monte_carlo.yaml").read_text())
    spec["scenario"] = str(ROOT / "scenarios" / "gust.yaml")
    gust = {**spec["overrides"]["wind.gusts"][0], "start_s": 0.5}
    spec["overrides"] |= {"duration_s": 3, "reference.altitude_m": 2, "wind.gusts": [gust],
                          "payload": [{"t_s": 2, "mass_kg": 0.0}], "expect.settle_s": 1, "end": "disarm"}
    path = folder / "gust_monte_carlo_short.yaml"
    path.write_text(yaml.safe_dump(spec, sort_keys=False))
    return path


@pytest.fixture(scope="module")
def monte_carlo(tmp_path_factory) -> tuple[Path, list[dict]]:
    out = tmp_path_factory.mktemp("mc")
    sweep = short_monte_carlo(out.parent)
    result = hil("sweep", str(sweep), "--limit", "40", "--jobs", "2", "--out", str(out))
    assert result.returncode == 0, result.stdout + result.stderr
    return out, read_parquet(out / "sweep.parquet")


@pytest.mark.slow
def test_forty_samples_on_a_local_cluster_equal_their_replays(monte_carlo, tmp_path):
    out, rows = monte_carlo
    assert len(rows) == 40 and [r["sample"] for r in rows] == list(range(40))
    assert {r["board.controller"] for r in rows} == {"smarc", "smpid", "backstepping"}
    assert all(r["reason"] for r in rows) and all(r["wall_s"] > 0 for r in rows if r["exit_code"] != 2)
    varied = ["seed", "wind.gusts[0].peak_ned", "wind.turbulence.intensity", "payload[0].mass_kg", "board.controller"]
    for row in (rows[0], rows[17], rows[38]):
        scenario = Path(row["command"].split()[2])
        assert row["seed"] == yaml.safe_load(scenario.read_text())["seed"]
        assert _rerun_alone(row, tmp_path) == flight_metrics(row, varied)
    text = (out / "sweep.md").read_text()
    assert "p99" in text and "hil run" in text and (out / "sweep_sensitivity.png").stat().st_size > 10_000


@pytest.mark.slow
def test_a_separately_started_dask_cluster_gives_the_same_results(monte_carlo, tmp_path):
    _, local_rows = monte_carlo
    port = free_port()
    scheduler = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                                  "--port", str(port), "--no-dashboard"], stdout=subprocess.DEVNULL,
                                 stderr=subprocess.DEVNULL, cwd=ROOT)
    workers = [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", f"tcp://127.0.0.1:{port}",
                                 "--nthreads", "1", "--no-dashboard"], stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL, cwd=ROOT) for _ in range(2)]
    try:
        out = tmp_path / "cluster"
        # the first draw, flown by each of the three controllers
        result = hil("sweep", str(short_monte_carlo(tmp_path)), "--limit", "3", "--cluster",
                     f"tcp://127.0.0.1:{port}", "--out", str(out))
        assert result.returncode == 0, result.stdout + result.stderr
    finally:
        for process in [*workers, scheduler]:
            process.send_signal(signal.SIGINT)
        for process in [*workers, scheduler]:
            process.wait(30)
    varied = ["seed", "wind.gusts[0].peak_ned", "wind.turbulence.intensity", "payload[0].mass_kg", "board.controller"]
    rows = read_parquet(out / "sweep.parquet")
    assert len(rows) == 3
    for remote, local in zip(rows, local_rows[:3], strict=True):
        assert {v: remote[v] for v in varied} == {v: local[v] for v in varied}
        assert flight_metrics(remote, varied) == flight_metrics(local, varied)
    assert "Dask cluster at tcp://127.0.0.1" in (out / "sweep.md").read_text()


def _comparable(rows: list[dict]) -> list[dict]:
    """A sweep's rows without what the wall clock decides (wall time, run directory names, timing)."""
    return [flight_metrics(r, []) | {"sample": r["sample"], "exit_code": r["exit_code"]} for r in rows]


@pytest.mark.slow
def test_ctrl_c_keeps_finished_samples_and_resume_gives_the_uninterrupted_result(tmp_path):
    # 2 draws x 2 controllers: the Ctrl-C lands at most 0.2 s after the second result while the third sample
    # flies for seconds, so 2 samples are left to --resume (any number left proves the same)
    sweep = tiny_sweep(tmp_path, samples_=2)
    whole = tmp_path / "whole"
    assert hil("sweep", str(sweep), "--out", str(whole)).returncode == 0
    stopped = tmp_path / "stopped"
    process = subprocess.Popen([sys.executable, "-m", "hil", "sweep", str(sweep), "--jobs", "1", "--out",
                                str(stopped)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    deadline = time.monotonic() + 300
    while len(list(stopped.glob("samples/*/result.json"))) < 2 and time.monotonic() < deadline:
        time.sleep(0.2)
    process.send_signal(signal.SIGINT)
    out, err = process.communicate(timeout=60)
    assert process.returncode == 130, out + err
    partial = read_parquet(stopped / "sweep.parquet")
    assert 2 <= len(partial) < 4 and "interrupted" in (stopped / "sweep.md").read_text()
    assert hil("sweep", str(sweep), "--resume", "--out", str(stopped)).returncode == 0
    assert _comparable(read_parquet(stopped / "sweep.parquet")) == _comparable(read_parquet(whole / "sweep.parquet"))


@pytest.mark.slow
def test_a_sample_that_cannot_fly_is_a_result_and_the_sweep_finishes(tmp_path):
    sweep = tmp_path / "heavy.yaml"
    sweep.write_text(f"name: heavy\nscenario: {tiny_hover(tmp_path)}\ndesign: grid\n"
                     "overrides: {duration_s: 3, payload: [{t_s: 0.5, mass_kg: 0.0}]}\n"
                     "vary:\n  payload[0].mass_kg: [0.0, 3.0]\n")
    out = tmp_path / "out"
    result = hil("sweep", str(sweep), "--out", str(out))
    assert result.returncode == 0, result.stderr
    light, heavy = read_parquet(out / "sweep.parquet")
    assert light["exit_code"] == 0
    # 4 × 5 N of thrust cannot hold 1 kg + 3 kg: a failed sample, with its reason
    assert heavy["exit_code"] != 0 and heavy["reason"] and heavy["reason"] != "completed"


def test_compare_says_when_seeds_cannot_change_a_deterministic_study(tmp_path):
    scenario = tmp_path / "still.yaml"
    scenario.write_text("name: still\nduration_s: 2\nexpect: {settle_s: 1}\nreference: {type: hover, altitude_m: 2}\n"
                        "end: disarm\n"
                        "sensors: {imu: {profile: ideal}, mag: {profile: ideal}, baro: {profile: ideal}, "
                        "gps: {profile: ideal}}\nboard: {state_source: truth}\n")
    result = hil("compare", str(scenario), "--controllers", "smarc", "--seeds", "2", "--out", str(tmp_path / "c"))
    assert result.returncode == 0, result.stderr
    assert "deterministic" in result.stdout and "seeds 0, 1 gave identical metrics" in result.stdout


def test_sample_values_reach_the_flown_scenario(tmp_path):
    spec = load_sweep(tiny_sweep(tmp_path))
    base = yaml.safe_load(tiny_hover(tmp_path).read_text())
    sample = Sample(0, {"seed": 42, "wind.steady_ned": [1.0, -2.0, 0.0], "board.controller": "smpid"})
    data = scenario_data(base, spec, sample)
    assert data["seed"] == 42 and data["wind"]["steady_ned"] == [1.0, -2.0, 0.0]
    assert data["board"]["controller"] == "smpid"
    assert base["seed"] == 1  # the base is not changed


def test_a_sample_that_sets_inside_an_override_leaves_the_override_and_other_samples_alone():
    spec = SweepSpec.model_validate({"name": "p", "scenario": "x.yaml", "design": "grid",
                                     "overrides": {"payload": [{"t_s": 1, "mass_kg": 0.0}]},
                                     "vary": {"payload[0].mass_kg": [0.5, 3.0]}})
    light, heavy = (scenario_data({"name": "b"}, spec, sample) for sample in samples(spec))
    assert light["payload"] == [{"t_s": 1, "mass_kg": 0.5}] and heavy["payload"] == [{"t_s": 1, "mass_kg": 3.0}]
    assert spec.overrides["payload"] == [{"t_s": 1, "mass_kg": 0.0}]
