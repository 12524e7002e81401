"""Flights of PX4's MAVSDK test cases against a bench whose pilot is someone else (`pilot: external`): the scenario
the bench judges them with, the bench as a process, a second ground station beside MAVSDK, and what the tests
check of each flight. The cases themselves are in tests/support/mavsdk_pilot.py."""

from __future__ import annotations

import json
import math
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

from mcap.reader import make_reader

from tests.support.ground_station import GroundStation
from tests.support.mavsdk_pilot import Findings, MavsdkTester, fly_blocking, global_of

ROOT = Path(__file__).resolve().parents[2]
HOME = (47.397742, 8.545594)  # the scenario's home (its default): the square is planned about it
SPEED_FACTOR = 4  # lockstep boards: a script needs no wall-clock time (PX4's timeouts follow PX4_SIM_SPEED_FACTOR)
SQUARE_ALTITUDE_M = 10.0


def square_items() -> list[dict[str, Any]]:
    """What MAVSDK's mission plugin uploads for the square (four NAV_WAYPOINTs, RTL appended), as the scenario
    writes the mission it expects the outside pilot to fly."""
    corners = [global_of(n, e, HOME) for n, e in ((20.0, 0.0), (20.0, 20.0), (0.0, 20.0), (0.0, 0.0))]
    return [*({"command": 16, "frame": 6, "params": [0, 0, 0, None, lat, lon, SQUARE_ALTITUDE_M]}
              for lat, lon in corners), {"command": 20, "frame": 2}]


# The landing is no criterion of PX4's cases (only that the vehicle lands, disarms and comes to rest near home), so
# it is flown at PX4's fastest land speed (MPC_LAND_SPEED up to MPC_Z_VEL_MAX_DN, 1.5 m/s, PX4's default for the
# descent above MPC_LAND_ALT1) and disarmed 0.5 s after PX4 detects the landing, not 2 s: of the HITL flight's
# 96 s wall clock the 10 m descent and the disarm took ~18 s at PX4's defaults (0.7 m/s below MPC_LAND_ALT2).
# The cases' geometry (take-off altitude, offboard setpoints, the 20 m square at 10 m) is PX4's, unchanged.
QUICK_LANDING = {"MPC_LAND_SPEED": 1.5, "COM_DISARM_LAND": 0.5}


def scenario(tmp_path: Path, name: str, expect: dict[str, Any], items: list[dict[str, Any]] | None = None) -> Path:
    pilot: dict[str, Any] = {"type": "external", **({"items": items} if items else {})}
    path = tmp_path / f"{name}.yaml"
    path.write_text(json.dumps({"name": name, "duration_s": 400, "seed": 3, "pilot": pilot, "expect": expect,
                                "board": {"params": QUICK_LANDING}}))
    return path


def start_bench(scenario_path: Path, runs: Path, *board: str) -> subprocess.Popen[str]:
    return subprocess.Popen([sys.executable, "-m", "hil", "run", str(scenario_path), *board, "--runs", str(runs),
                             "--no-telemetry", "--no-report"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, cwd=ROOT)


def px4_instance(runs: Path, timeout_s: float = 60.0) -> int:
    """The instance of the PX4 the bench started under `runs` (its -i argument): its ports follow from it."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        for proc in Path("/proc").iterdir():
            try:
                argv = (proc / "cmdline").read_bytes().decode(errors="replace").split("\0")
            except OSError:
                continue
            if argv[0].endswith("bin/px4") and str(runs) in " ".join(argv) and "-i" in argv:
                return int(argv[argv.index("-i") + 1])
        time.sleep(0.2)
    raise AssertionError(f"no PX4 started under {runs} within {timeout_s:g} s")


def finish(bench: subprocess.Popen[str], findings: Findings) -> tuple[str, Path]:
    """The bench's summary once it has ended (at once, with Ctrl-C, when the script could not fly to the end)."""
    if any(f.startswith("REQUIRE") for f in findings.failures):
        bench.send_signal(signal.SIGINT)
    out, err = bench.communicate(timeout=600)
    assert bench.returncode in (0, 1, 130), out + err
    run_dir = Path(out.split("run directory: ")[1].split()[0])
    return out, run_dir


def verdicts(run_dir: Path) -> dict[str, dict[str, Any]]:
    return {v["expectation"]: v for v in json.loads((run_dir / "metrics.json").read_text())["verdicts"]}


def true_rest_from_home_m(run_dir: Path) -> float:
    """Where the vehicle came to rest, horizontally from home, read from the recording's truth."""
    with open(run_dir / "recording.mcap", "rb") as f:
        last = None
        for _, _, message in make_reader(f).iter_messages(topics=["hil/state"]):
            last = message
    assert last is not None
    north, east, _ = json.loads(last.data)["pos_ned"]
    return math.hypot(north, east)


async def takeoff_offboard_and_land(tester: MavsdkTester) -> None:
    """ "Takeoff and Land" with "Offboard position control" between: arm, take off, the four setpoints, land."""
    await tester.wait_until_ready()
    await tester.arm()
    await tester.takeoff_and_hover()
    await tester.offboard_setpoints()
    await tester.land_and_wait_disarmed()


class SecondGroundStation(threading.Thread):
    """pymavlink, as QGroundControl would be, beside MAVSDK: heartbeats, a parameter, the mission downloaded."""

    def __init__(self, endpoint: str, vehicle: int) -> None:
        super().__init__(daemon=True)
        self.station = GroundStation(endpoint, vehicle)
        self.uploaded = threading.Event()
        self.results: dict[str, Any] = {}

    def run(self) -> None:
        try:
            self.results["heartbeats"] = self.station.wait_heartbeats(3, 60)
            self.results["MIS_TAKEOFF_ALT"] = self.station.read_param("MIS_TAKEOFF_ALT")
            if self.uploaded.wait(120):
                self.results["mission"] = self.station.download_mission()
        finally:
            self.station.close()


def square_mission_with_a_second_station(station: SecondGroundStation):
    async def flight(tester: MavsdkTester) -> None:
        """ "Fly square Multicopter Missions including RTL" (its items planned about the scenario's home), with
        the other ground station downloading the mission before the flight."""
        await tester.wait_until_ready()
        await tester.upload_square_mission(HOME, altitude_m=SQUARE_ALTITUDE_M)
        station.uploaded.set()
        await tester.drone.action.get_takeoff_altitude()  # a parameter read while the other station reads its own
        for _ in range(200):
            if "mission" in station.results:
                break
            await tester.poll(lambda: False, 0.1)
        await tester.arm()
        await tester.execute_mission_tracked(HOME, SQUARE_ALTITUDE_M)
        await tester.wait_until_disarmed(180)
    return flight


def px4_said(run_dir: Path) -> str:
    """PX4's warnings and errors of the run (its console, kept in the run directory when the bench started PX4)."""
    log = run_dir / "px4.log"
    lines = log.read_text(errors="replace").splitlines() if log.exists() else []
    return "\n".join(line for line in lines if line.startswith(("WARN", "ERROR")))


def assert_the_square_flight(findings: Findings, station: SecondGroundStation, out: str, run_dir: Path) -> None:
    assert findings.failures == [], f"{findings}\n{out}\nPX4:\n{px4_said(run_dir)}"
    assert findings.mission_finished and findings.disarmed and findings.max_cross_track_m < 5.0
    assert station.results["heartbeats"] and station.results["MIS_TAKEOFF_ALT"] is not None
    downloaded = station.results["mission"]
    assert downloaded is not None, "the second ground station could not download the mission"
    assert [item.command for item in downloaded] == [item["command"] for item in square_items()]
    for got, planned in zip(downloaded[:4], square_items()[:4], strict=True):
        assert abs(got.lat_deg - planned["params"][4]) < 2e-7 and abs(got.lon_deg - planned["params"][5]) < 2e-7
    assert "result: PASS" in out, out
    judged = verdicts(run_dir)
    assert all(v["met"] for v in judged.values()), judged
    assert true_rest_from_home_m(run_dir) < 2.0


def fly_through_the_relay(tmp_path: Path, *board: str) -> None:
    """A board on one link (PX4's HITL path, the emulator): the bench's relay serves MAVSDK and a ground station
    on two ports at once. One flight: take-off, the offboard setpoints, then the square mission with RTL."""
    expect = {"mission_completed": True, "home_within_m": 2.0, "max_cross_track_m": 5.0,
              "modes_seen": ["AUTO.TAKEOFF", "OFFBOARD", "AUTO.MISSION", "AUTO.RTL"], "disarmed_by_s": 240}
    api_port, gcs_port = free_udp_port(), free_udp_port()
    bench = start_bench(scenario(tmp_path, "mavsdk_relayed", expect, square_items()), tmp_path / "runs", *board,
                        "--gcs", f"udpout:127.0.0.1:{api_port}", "--gcs", f"udpout:127.0.0.1:{gcs_port}")
    try:  # PX4's instance N is MAVLink system N+1: not 1 when another test's PX4 holds instance 0
        vehicle = px4_instance(tmp_path / "runs") + 1 if "--px4-hitl" in board else 1
    except AssertionError:
        bench.send_signal(signal.SIGINT)  # no PX4 to fly: the bench ends its run as on Ctrl-C
        bench.communicate(timeout=60)
        raise
    station = SecondGroundStation(f"udpin:127.0.0.1:{gcs_port}", vehicle)
    station.start()

    async def flight(tester: MavsdkTester) -> None:
        await tester.wait_until_ready()
        await tester.upload_square_mission(HOME, altitude_m=SQUARE_ALTITUDE_M)
        station.uploaded.set()
        await tester.arm()
        await tester.takeoff_and_hover()
        await tester.offboard_setpoints()
        await tester.execute_mission_tracked(HOME, SQUARE_ALTITUDE_M)
        await tester.wait_until_disarmed(180)

    findings = Findings()
    try:
        findings = fly_blocking(f"udpin://127.0.0.1:{api_port}", flight, 900, bench)
    finally:
        out, run_dir = finish(bench, findings)
    assert_the_square_flight(findings, station, out, run_dir)
    assert max(findings.offboard_errors_m) < 0.3


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])
