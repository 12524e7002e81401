"""`hil run scenarios/patrol_mission.yaml`: the bench as the ground station that starts PX4's mission (`pilot:
mission`), on PX4 SITL and on PX4's HITL path. What the bench says is checked against PX4's own flight log (ULog,
read with pyulog): PX4 flew AUTO.MISSION, reached the items it reports reached, went to AUTO.RTL, landed and
disarmed; the gusts acted while the legs were flown. One flight per board kind.

Needs HIL_PX4_DIR (tests/support/px4_builds.py).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap.reader import make_reader
from pyulog import ULog

from tests.support.px4_builds import px4_build, px4_root

PX4_ROOT = px4_root()
pytestmark = [pytest.mark.px4, pytest.mark.slow]
ROOT = Path(__file__).resolve().parent.parent
PATROL = ROOT / "scenarios" / "patrol_mission.yaml"
NAV_AUTO_MISSION, NAV_AUTO_RTL = 3, 5  # PX4 vehicle_status.nav_state
ARMING_STATE_ARMED, ARMING_STATE_DISARMED = 2, 1
LEGS = (2, 3, 4)  # patrol_mission.plan: the items the span's legs lead to (0 take-off, 1 speed, 5 RTL)


@pytest.fixture(scope="module")
def sitl(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return px4_build(PX4_ROOT, "sitl", tmp_path_factory.mktemp("px4"))


@pytest.fixture(scope="module")
def hitl(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return px4_build(PX4_ROOT, "hitl", tmp_path_factory.mktemp("px4"))


def fly_patrol(tmp_path: Path, *board: str) -> tuple[subprocess.CompletedProcess[str], Path]:
    runs = os.path.relpath(tmp_path, ROOT)  # as a user types it (PX4 runs in a rootfs under it)
    result = subprocess.run([sys.executable, "-m", "hil", "run", str(PATROL), *board, "--runs", runs,
                             "--no-telemetry"], capture_output=True, text=True, timeout=600, cwd=ROOT)
    (run_dir,) = [p for p in tmp_path.iterdir() if p.is_dir()]
    return result, run_dir


def recorded(run_dir: Path, topic: str) -> list[dict[str, Any]]:
    with open(run_dir / "recording.mcap", "rb") as f:
        return [json.loads(m.data) for _, _, m in make_reader(f).iter_messages(topics=[topic])]


def first_index(values: Any, wanted: int, after: int = 0) -> int:
    hits = [i for i, v in enumerate(values) if v == wanted and i >= after]
    assert hits, f"{wanted} never logged after sample {after}"
    return hits[0]


def assert_px4_flew_the_mission(run_dir: Path) -> None:
    """PX4's ULog: AUTO.MISSION, then AUTO.RTL; every item the bench recorded as reported reached is one PX4
    logged as reached (mission_result.seq_reached), and its current item went through the whole mission; landed
    and disarmed at the end."""
    (log,) = sorted((run_dir / "px4" / "log").rglob("*.ulg"))
    ulog = ULog(str(log), ["vehicle_status", "mission_result", "vehicle_land_detected"])
    status = ulog.get_dataset("vehicle_status").data
    mission = first_index(status["nav_state"], NAV_AUTO_MISSION)
    first_index(status["nav_state"], NAV_AUTO_RTL, after=mission)
    assert status["arming_state"][-1] == ARMING_STATE_DISARMED
    result = ulog.get_dataset("mission_result").data
    logged_reached = {int(s) for s in result["seq_reached"] if s >= 0}
    reported = {m["seq"] for m in recorded(run_dir, "hil/board/mission_item_reached")}
    assert reported == logged_reached and reported >= set(LEGS), (reported, logged_reached)
    assert int(max(result["seq_current"])) == 5 and int(result["seq_total"][-1]) == 6
    landed = ulog.get_dataset("vehicle_land_detected").data["landed"]
    took_off = first_index(landed, 0)
    first_index(landed, 1, after=took_off)


def assert_the_gusts_hit_the_legs(run_dir: Path) -> None:
    """Each gust of the scenario peaks while the board's current item is one of the span's legs."""
    current = [(m["t_us"], m["seq"]) for m in recorded(run_dir, "hil/board/mission_current")]
    steady = np.array([1.0, -1.7, 0.0])
    environment = recorded(run_dir, "hil/environment")
    gust = np.array([np.linalg.norm(np.array(e["wind_ned"]) - steady) for e in environment])
    t_us = np.array([e["t_us"] for e in environment])
    state = {s["t_us"]: s["mission_t"] for s in recorded(run_dir, "hil/state")
             if s["mission_t"] is not None}  # JSON's null: before take-off (-inf)
    for start_s in (12.0, 28.0):  # the scenario's gusts: 3 s each, peak at the middle
        peak_us = next(t for t in t_us if state.get(int(t), -1.0) >= start_s + 1.5)
        leg = [seq for t, seq in current if t <= peak_us][-1]
        assert leg in LEGS, f"the gust at {start_s:g} s peaked while item {leg} was flown"
        window = (t_us >= peak_us - 500_000) & (t_us <= peak_us + 500_000)
        assert gust[window].max() > 3.0  # 4 m/s peak across the span, over the steady wind and turbulence


def assert_the_verdicts(result: subprocess.CompletedProcess[str], run_dir: Path) -> dict[str, Any]:
    assert result.returncode == 0, result.stdout + result.stderr
    metrics = json.loads((run_dir / "metrics.json").read_text())
    verdicts = {v["expectation"]: v for v in metrics["verdicts"]}
    assert {"mission_completed", "home_within_m", "max_cross_track_m"} <= set(verdicts)
    assert all(v["met"] for v in verdicts.values()), verdicts
    events = [e["text"] for e in recorded(run_dir, "hil/events")]
    assert sum(text.startswith("expect met: ") for text in events) == len(verdicts)
    return metrics


def test_patrol_mission_flies_on_px4_sitl_as_its_ulog_shows(sitl, tmp_path):
    result, run_dir = fly_patrol(tmp_path, "--px4", str(sitl))
    metrics = assert_the_verdicts(result, run_dir)
    assert_px4_flew_the_mission(run_dir)
    assert_the_gusts_hit_the_legs(run_dir)
    assert metrics["phase_reached"] == "done" and "report:" in result.stdout


def test_patrol_mission_flies_on_px4_hitl_as_its_ulog_shows(hitl, tmp_path):
    result, run_dir = fly_patrol(tmp_path, "--px4-hitl", str(hitl), "--no-report", "--no-gcs")  # no stray UDP
    assert_the_verdicts(result, run_dir)
    assert_px4_flew_the_mission(run_dir)
    assert_the_gusts_hit_the_legs(run_dir)
