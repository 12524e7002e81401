"""The shipped failsafe scenarios on the emulator, as `hil run` flies them (the session's shipped flights: no flight
of their own), checked against what the bench sent and the board answered on the wire (link.tlog, read with
pymavlink) and against PX4's parameters: each trigger when the bench made it, each reaction within the time the
parameters imply, and the battery, sticks and ground station as sent. And a scenario that expects the wrong action
fails, saying what the board did instead, its battery published on Zenoh."""

from __future__ import annotations

import itertools
import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import jsonschema
import pytest
import yaml

from firmware_interface.px4_modes import FlightMode
from hil.channels import json_schema
from tests.support.cli_runs import run
from tests.support.failsafe_logs import event_us, last_sent_us, mission_start_us, mode_us, recorded, tlog_frames
from tests.support.ports import free_port, wait_listening

pytestmark = [pytest.mark.e2e, pytest.mark.slow]
ROOT = Path(__file__).resolve().parent.parent
SCENARIOS = ROOT / "scenarios"
TICK_S = 0.05  # the emulator's commander decides at 20 Hz


def verdict(run_dir: Path) -> dict:
    metrics = json.loads((run_dir / "metrics.json").read_text())
    assert metrics["exit_code"] == 0, metrics["reason"]
    (found,) = [v for v in metrics["verdicts"] if v["expectation"] == "failsafe"]
    assert found["met"], found
    return metrics["behaviour"]["failsafe"]


def passed(result: subprocess.CompletedProcess[str]) -> None:
    assert result.returncode == 0, result.stdout + result.stderr


def test_battery_rtl_returns_at_the_critical_level_it_was_sent(shipped_flight):
    """The recording's battery samples (valid against their channel's schema) come every 0.5 s (2 Hz) and each is
    in link.tlog as the battery component's
    BATTERY_STATUS, in mV per cell; the first sent below BAT_CRIT_THR 14.5 % is the trigger; the emulator holds
    COM_FAIL_ACT_T (5 s) and returns, landing within 2 m of home."""
    result, run_dir = shipped_flight(SCENARIOS / "battery_rtl.yaml")
    passed(result)
    figures = verdict(run_dir)
    samples = recorded(run_dir, "battery")
    for sample in samples:
        jsonschema.validate(sample, json.loads(json_schema("battery")))
    assert {b["t_us"] - a["t_us"] for a, b in itertools.pairwise(samples[1:])} == {500_000}
    sent = [f for f in tlog_frames(run_dir) if f.kind == "BATTERY_STATUS"]
    assert len(sent) == len(samples)
    for frame, sample in zip(sent, samples, strict=True):
        assert frame.message.get_srcComponent() == 180
        assert list(frame.message.voltages[:4]) == [round(v * 1000) for v in sample["cell_voltages_v"]]
    start = mission_start_us(run_dir)
    trigger = next(s for s in samples if round(s["remaining"] * 100) < 14.5)
    assert figures["trigger_at_mission_s"] == pytest.approx((trigger["t_us"] - start) * 1e-6)
    low = event_us(run_dir, "board: Low battery level", after_us=trigger["t_us"] - 1)  # critical (low: 20 %)
    assert trigger["t_us"] <= low <= trigger["t_us"] + TICK_S * 1e6
    assert event_us(run_dir, "board: Failsafe activated: entering Hold for 5 seconds") - low <= TICK_S * 1e6
    returned = mode_us(run_dir, FlightMode.AUTO_RTL)
    assert 5.0 <= (returned - low) * 1e-6 <= 5.0 + 1.0 + TICK_S  # the hold, then the next 1 Hz HEARTBEAT
    assert figures["reaction"] == "AUTO.RTL" and figures["landed_from_home_m"] < 2.0


def test_datalink_loss_stops_the_ground_stations_traffic_only(shipped_flight):
    """From the loss on, link.tlog has no HEARTBEAT of the bench's (type GCS) and no command, while its HIL frames
    go on to the end; the emulator declares the link lost COM_DL_LOSS_T (10 s) after the last heartbeat (within
    its 20 Hz tick) and returns after COM_FAIL_ACT_T (5 s)."""
    result, run_dir = shipped_flight(SCENARIOS / "datalink_loss.yaml")
    passed(result)
    frames = tlog_frames(run_dir)
    lost_us = mission_start_us(run_dir) + 20_000_000
    last_beat = last_sent_us(frames, "HEARTBEAT")
    assert lost_us - 1_000_000 <= last_beat < lost_us
    assert last_sent_us(frames, "HIL_SENSOR") > lost_us + 30_000_000
    declared = event_us(run_dir, "board: Connection to ground station lost")
    assert 10.0 < (declared - last_beat) * 1e-6 <= 10.0 + TICK_S + 0.004
    assert 5.0 <= (mode_us(run_dir, FlightMode.AUTO_RTL) - declared) * 1e-6 <= 5.0 + 1.0 + TICK_S
    assert verdict(run_dir)["landed_from_home_m"] < 2.0


def test_manual_control_loss_after_sticks_at_25_hz(shipped_flight):
    """The sticks are sent at 25 Hz in PX4's range (the recording and the MANUAL_CONTROL frames agree: z = 500 for
    a centred throttle) and none in the loss; the emulator enters its hold COM_RC_LOSS_T (0.5 s) after the last one,
    returns COM_FAIL_ACT_T (5 s) later, and lands within 2 m of home."""
    result, run_dir = shipped_flight(SCENARIOS / "manual_control_loss.yaml")
    passed(result)
    sticks = recorded(run_dir, "manual_control")
    for sample in sticks:
        jsonschema.validate(sample, json.loads(json_schema("manual_control")))
    frames = [f for f in tlog_frames(run_dir) if f.kind == "MANUAL_CONTROL"]
    assert len(frames) == len(sticks)
    for frame, sample in zip(frames, sticks, strict=True):
        assert frame.message.z == round((sample["throttle"] + 1) * 500) and frame.message.x == round(
            sample["pitch"] * 1000)
    lost_us = mission_start_us(run_dir) + 17_000_000
    assert {b["t_us"] - a["t_us"] for a, b in itertools.pairwise(sticks[1:])} == {40_000}
    last = sticks[-1]["t_us"]
    assert lost_us - 40_000 <= last < lost_us
    hold = event_us(run_dir, "board: Failsafe activated: entering Hold for 5 seconds")
    assert 0.5 < (hold - last) * 1e-6 <= 0.5 + TICK_S + 0.004
    assert 5.0 <= (mode_us(run_dir, FlightMode.AUTO_RTL) - hold) * 1e-6 <= 5.0 + 1.0 + TICK_S
    assert verdict(run_dir)["landed_from_home_m"] < 2.0


def test_gps_loss_descends_blind_after_ekf2_noaid_tout(shipped_flight):
    """No HIL_GPS after the dropout; EKF2_NOAID_TOUT (5 s) after the last fix the emulator has no position and
    descends (AUTO.LAND), and its land detector disarms it on the ground."""
    result, run_dir = shipped_flight(SCENARIOS / "gps_loss.yaml")
    passed(result)
    dropped_us = mission_start_us(run_dir) + 18_000_000
    fixes = [f.t_us for f in tlog_frames(run_dir) if f.kind == "HIL_GPS"]
    last_fix = recorded(run_dir, "sensors/gps")[-1]["t_us"]
    assert len(fixes) == len(recorded(run_dir, "sensors/gps")) and dropped_us - 200_000 <= last_fix < dropped_us
    activated = event_us(run_dir, "board: Failsafe activated")
    assert 5.0 < (activated - last_fix) * 1e-6 <= 5.0 + TICK_S
    figures = verdict(run_dir)
    assert figures["reaction"] == "AUTO.LAND" and figures["landed_at_mission_s"] is not None


def test_a_wrong_action_fails_with_what_the_board_did_instead_and_the_battery_is_on_zenoh(tmp_path):
    """battery_short expecting a landing: exit 1, and the summary's line says the board returned instead. A Zenoh
    subscriber in another process (`hil echo`) gets the battery channel: every sample the recording has."""
    scenario = yaml.safe_load((ROOT / "tests" / "data" / "failsafes" / "battery_short.yaml").read_text())
    scenario["expect"]["failsafe"] = {"after": "battery low", "action": "land", "within_s": 8}
    path = tmp_path / "battery_wrong.yaml"
    path.write_text(yaml.safe_dump(scenario))
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with open(tmp_path / "echo.jsonl", "wb") as sink:
        echo = subprocess.Popen([sys.executable, "-m", "hil", "echo", "hil/*/battery", "--zenoh-listen", endpoint],
                                stdout=sink, stderr=subprocess.DEVNULL, cwd=ROOT)
        wait_listening(int(endpoint.rsplit(":", 1)[1]))
        result, run_dir = run(path, tmp_path / "runs", "--no-gcs", "--no-report", "--zenoh-connect", endpoint)
        time.sleep(1.0)
        echo.send_signal(signal.SIGINT)
        assert echo.wait(10) == 0
    assert result.returncode == 1, result.stdout + result.stderr
    summary = " ".join((run_dir / "summary.txt").read_text().split())
    assert "expectations: NOT met" in summary and "- failsafe: battery low at mission time" in summary
    assert "instead of AUTO.LAND (expected land within 8 s of battery low)" in summary
    published = [json.loads(line)["sample"] for line in (tmp_path / "echo.jsonl").read_text().splitlines()]
    assert published and published == recorded(run_dir, "battery")[-len(published):]
