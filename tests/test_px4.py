"""The bench against real, unmodified PX4 v1.15.4: SITL in lockstep (`--px4`) and PX4's HITL code path
on a pty (`--px4-hitl`). Checked against PX4's own flight log (ULog, read with pyulog) and its console.

Needs HIL_PX4_DIR (see tests/support/px4_builds.py); CI sets it, and a missing PX4 fails CI rather than skipping.
"""

from __future__ import annotations

import ctypes
import json
import os
import signal
import subprocess
import sys
import threading
import time
from collections import Counter
from contextlib import suppress
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap.reader import make_reader
from pymavlink import mavutil
from pyulog import ULog

from firmware_interface.board_watchdog import BOOT_US
from hil.boards.px4 import Px4Build
from hil.boards.px4_sitl import Px4SitlTarget
from hil.exit_codes import EXIT_BOARD, EXIT_INTERRUPTED
from hil.loop.frame import StepFrame
from hil.loop.sink import FrameSink
from hil.outputs.telemetry import subscribe
from hil.outputs.zenoh_session import ZenohOptions
from hil.run.runner import RunOptions, RunOutcome, run_scenario
from hil.scenario.loader import load_scenario
from tests.support.mavsdk_client import read_telemetry
from tests.support.ports import free_port
from tests.support.px4_builds import px4_root
from tests.support.summary_text import summary_field

PX4_ROOT = px4_root()
pytestmark = [pytest.mark.px4, pytest.mark.slow]
ROOT = Path(__file__).resolve().parent.parent
BENCH_COMPONENT = 51  # firmware_interface.board.BENCH_COMPONENT_ID: PX4 acks our commands to it
ARMING_STATE_DISARMED, ARMING_STATE_ARMED = 1, 2  # PX4 vehicle_status.arming_state
NAV_STATE_OFFBOARD, NAV_STATE_AUTO_LAND = 14, 18  # PX4 vehicle_status.nav_state


def short_hover(folder: Path, quick_landing: bool = False) -> Path:
    """hover.yaml's flight cut to a 3 s hold 3 m up, for the tests that stop or judge a flight but not its
    figures: each of its phases comes sooner, and a whole flight takes ~25 s simulated instead of ~70.
    `quick_landing`: PX4 lands at 1.5 m/s (MPC_LAND_SPEED up to MPC_Z_VEL_MAX_DN; 0.7 by default) and disarms 0.5 s
    after it detects the landing (COM_DISARM_LAND, 2 s), for a wall-clock flight judged on its phases' order, not
    on how long the landing took (~4.5 s less of the ~8 s descent and the 2 s wait)."""
    path = folder / "short_hover.yaml"
    landing = "board: {params: {MPC_LAND_SPEED: 1.5, COM_DISARM_LAND: 0.5}}\n" if quick_landing else ""
    path.write_text("name: short_hover\nduration_s: 3\nseed: 1\nreference: {type: hover, altitude_m: 3}\n" + landing)
    return path


def hil_run(*args: str, runs: Path, timeout: float = 300) -> subprocess.CompletedProcess[str]:
    """`runs` is given relative to the working directory, as a user types it (PX4 runs in a rootfs under it)."""
    relative = os.path.relpath(runs, ROOT)
    return subprocess.run([sys.executable, "-m", "hil", "run", *args, "--runs", relative, "--no-telemetry"],
                          capture_output=True, text=True, timeout=timeout, cwd=ROOT)


def only_run_dir(runs: Path) -> Path:
    dirs = [p for p in runs.iterdir() if p.is_dir()]
    assert len(dirs) == 1, dirs
    return dirs[0]


def live_processes() -> dict[int, list[str]]:
    """pid -> argv of every live (not zombie) process."""
    found = {}
    for proc in Path("/proc").iterdir():
        if not proc.name.isdigit():
            continue
        try:
            argv = (proc / "cmdline").read_bytes().decode(errors="replace").split("\0")
            state = (proc / "stat").read_text().split(") ")[-1][:1]
        except OSError:  # gone meanwhile
            continue
        if state != "Z":
            found[int(proc.name)] = argv
    return found


def processes_using(path: Path) -> list[str]:
    """Command lines of live processes that mention `path` (PX4's rootfs is in the run directory)."""
    return [" ".join(argv) for argv in live_processes().values() if str(path) in " ".join(argv)]


def flight_log(run_dir: Path) -> ULog:
    logs = sorted((run_dir / "px4" / "log").rglob("*.ulg"))
    assert logs, f"PX4 wrote no ULog under {run_dir / 'px4' / 'log'}"
    return ULog(str(logs[-1]), ["vehicle_status", "vehicle_land_detected", "vehicle_command_ack",
                                "vehicle_angular_velocity_groundtruth"])


def first_after(t_us: Any, values: Any, wanted: int, after_us: int) -> int:
    hits = [int(t) for t, v in zip(t_us, values, strict=True) if v == wanted and t > after_us]
    assert hits, f"value {wanted} never seen after t = {after_us} us"
    return hits[0]


def assert_px4_flew_the_whole_flight(ulog: ULog) -> None:
    """From PX4's own log: armed, then OFFBOARD, took off, landed, and disarmed, in that order."""
    status = ulog.get_dataset("vehicle_status").data
    land = ulog.get_dataset("vehicle_land_detected").data
    armed = first_after(status["timestamp"], status["arming_state"], ARMING_STATE_ARMED, 0)
    offboard = first_after(status["timestamp"], status["nav_state"], NAV_STATE_OFFBOARD, armed - 1)
    took_off = first_after(land["timestamp"], land["landed"], 0, armed)
    landed = first_after(land["timestamp"], land["landed"], 1, took_off)
    disarmed = first_after(status["timestamp"], status["arming_state"], ARMING_STATE_DISARMED, landed - 1)
    assert armed <= offboard < landed < disarmed + 1
    assert status["arming_state"][-1] == ARMING_STATE_DISARMED


def recorded(run_dir: Path, topic: str) -> list[dict[str, Any]]:
    with open(run_dir / "recording.mcap", "rb") as f:
        return [json.loads(m.data) for _, _, m in make_reader(f).iter_messages(topics=[topic])]


def assert_every_ack_reached_the_bench(ulog: ULog, run_dir: Path) -> None:
    acks = ulog.get_dataset("vehicle_command_ack").data
    sent = Counter((int(c), int(r))
                   for c, r, comp in zip(acks["command"], acks["result"], acks["target_component"], strict=True)
                   if comp == BENCH_COMPONENT)
    seen = Counter((m["command"], m["result"]) for m in recorded(run_dir, "hil/board/command_ack"))
    assert sent, "PX4 logged no acknowledgement addressed to the bench"
    assert not sent - seen, f"acknowledged by PX4 but missing from the recording: {sent - seen}"


@pytest.mark.parametrize("scenario", ["hover", "gust"])
def test_sitl_flies_the_scenario_from_arming_to_disarm(sitl, tmp_path, scenario):
    result = hil_run(f"scenarios/{scenario}.yaml", "--px4", str(sitl), runs=tmp_path)
    assert result.returncode == 0, result.stdout + result.stderr
    run_dir = only_run_dir(tmp_path)
    ulog = flight_log(run_dir)
    assert_px4_flew_the_whole_flight(ulog)
    assert_every_ack_reached_the_bench(ulog, run_dir)
    assert_px4_logged_the_true_rates_at_their_own_time(ulog, run_dir)
    console = (run_dir / "px4.log").read_text()
    assert "Simulator connected" in console
    assert "poll timeout" not in console.split("Simulator connected", 1)[1]
    assert not processes_using(run_dir)
    assert (run_dir / "report.html").stat().st_size > 100_000  # the run's page, from PX4's flight
    texts = [m["text"] for m in recorded(run_dir, "hil/board/statustext")]
    assert "Landing detected" in texts  # STATUSTEXT reaches the bench: PX4 takes it for a GCS
    metrics = json.loads((run_dir / "metrics.json").read_text())
    assert set(metrics["board_estimate_error_m"]) == {"x", "y", "z"}
    assert_px4_stopped_the_streams_the_bench_does_not_read(run_dir, metrics)
    assert_setpoints_streamed_at_a_companions_rate_and_px4_stayed_in_offboard(ulog, run_dir)


def assert_setpoints_streamed_at_a_companions_rate_and_px4_stayed_in_offboard(ulog: ULog, run_dir: Path) -> None:
    """The bench's SET_POSITION_TARGET_LOCAL_NED on SITL's command link, as the link's tlog holds them: one every
    20 ms of the bench's clock (their own time_boot_ms), never sooner after the second (the schedule keeps to
    multiples of 20 ms; the stream starts at whichever step it starts). And PX4, which leaves OFFBOARD for a
    failsafe when the stream lapses (COM_OF_LOSS_T), left it only for the AUTO.LAND the bench asked for."""
    boot_ms = []
    tlog = mavutil.mavlink_connection(str(run_dir / "link.tlog"))
    while (msg := tlog.recv_match(type="SET_POSITION_TARGET_LOCAL_NED")) is not None:
        boot_ms.append(msg.time_boot_ms)
    gaps = np.diff(boot_ms)[1:]
    assert len(boot_ms) > 500 and gaps.min() >= 20 and np.median(gaps) == 20, (len(boot_ms), np.unique(gaps))
    status = ulog.get_dataset("vehicle_status").data
    offboard = first_after(status["timestamp"], status["nav_state"], NAV_STATE_OFFBOARD, 0)
    after = [int(v) for t, v in zip(status["timestamp"], status["nav_state"], strict=True) if t >= offboard]
    assert next(v for v in after if v != NAV_STATE_OFFBOARD) == NAV_STATE_AUTO_LAND, after


def assert_px4_logged_the_true_rates_at_their_own_time(ulog: ULog, run_dir: Path) -> None:
    """PX4 SITL logs HIL_STATE_QUATERNION's body rates as vehicle_angular_velocity_groundtruth, stamped with its
    lockstep clock (the last HIL_SENSOR's time_usec) when it reads the message. Each logged sample must be the
    bench's true rates at that very time, to float32 rounding (a step off is ~1e-2 rad/s in this flight)."""
    logged = ulog.get_dataset("vehicle_angular_velocity_groundtruth").data
    truth = {m["t_us"]: m["rates_frd"] for m in recorded(run_dir, "hil/state")}
    pairs = [(np.array((x, y, z)), np.array(truth[int(t)]))
             for t, x, y, z in zip(logged["timestamp"], logged["xyz[0]"], logged["xyz[1]"], logged["xyz[2]"],
                                   strict=True) if int(t) in truth]
    assert len(pairs) > 0.9 * len(logged["timestamp"]) > 1000  # 100 Hz over the flight, on the bench's steps
    worst = max(float(np.abs(px4 - bench).max()) for px4, bench in pairs)
    assert worst < 1e-6, f"PX4's logged ground truth is off the bench's truth at the same time by {worst:.2e} rad/s"


def assert_px4_stopped_the_streams_the_bench_does_not_read(run_dir: Path, metrics: dict[str, Any]) -> None:
    """PX4's onboard link streams HIGHRES_IMU at 50 Hz and LOCAL_POSITION_NED at 30 Hz (mavlink_main.cpp,
    MAVLINK_MODE_ONBOARD). The bench reads the latter and asks PX4 to stop the former once it has seen it
    (MAV_CMD_SET_MESSAGE_INTERVAL, -1): over the whole flight far fewer HIGHRES_IMU than LOCAL_POSITION_NED
    must reach the command link, where without the request there would be 5/3 as many."""
    assert "HIGHRES_IMU" in metrics["board_streams_stopped"]
    assert "LOCAL_POSITION_NED" not in metrics["board_streams_stopped"]
    counts: Counter[str] = Counter()
    tlog = mavutil.mavlink_connection(str(run_dir / "link.tlog"))
    while (msg := tlog.recv_match()) is not None:
        if msg.get_srcComponent() == 1:  # PX4's autopilot component, not the bench's frames
            counts[msg.get_type()] += 1
    assert counts["LOCAL_POSITION_NED"] > 1000  # ~30 Hz over a minute of flight: still streamed
    assert counts["HIGHRES_IMU"] < 0.2 * counts["LOCAL_POSITION_NED"]


def test_hitl_rehearsal_flies_the_serial_path_in_real_time_and_a_gcs_sees_px4_through_the_relay(hitl, tmp_path):
    """The short hover on PX4's HITL path (paced by the wall clock, as a Pixhawk needs): its whole flight in PX4's
    log, PX4's own messages to a ground station through the relay, every unknown message passed through."""
    bench = subprocess.Popen([sys.executable, "-m", "hil", "run", "--no-report",
                              str(short_hover(tmp_path, quick_landing=True)), "--px4-hitl", str(hitl),
                              "--runs", os.path.relpath(tmp_path, ROOT), "--no-telemetry",
                              "--gcs", "udpout:127.0.0.1:14593"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        seen = read_telemetry(14593, 90, want_status_text=True)  # MAVSDK, as QGroundControl would connect
    finally:
        out, err = bench.communicate(timeout=300)
    assert bench.returncode == 0, out + err
    assert abs(seen["position"].latitude_deg - 47.397742) < 1e-3 and seen["armed"] is True
    assert seen["flight_mode"] == "OFFBOARD" and seen["status_text"]  # PX4's own STATUSTEXT reached the GCS
    run_dir = only_run_dir(tmp_path)
    assert_px4_flew_the_whole_flight(flight_log(run_dir))
    assert not processes_using(run_dir)
    metrics = json.loads((run_dir / "metrics.json").read_text())
    # PX4's common-dialect messages that pymavlink lacks (ids 8, 290, 291, 380, 410, 411, 436) pass through
    assert metrics["link"]["unknown_id"] == 0 and metrics["link"]["passed_through"] > 0
    timing = metrics["timing"]
    assert set(timing["period_jitter_us"]) == {"p50", "p99", "max"}
    assert "late_steps" in timing
    sim_s, wall_s = timing["sim_s"], timing["wall_s"]
    assert sim_s == pytest.approx(wall_s, rel=0.05)  # wall-clock pacing, as a Pixhawk needs


def test_arming_refused_by_px4_puts_its_reason_in_the_summary(sitl, tmp_path):
    scenario = tmp_path / "nofix.yaml"  # no GPS fix: PX4's preflight checks never pass
    scenario.write_text("name: nofix\nduration_s: 5\nsensors: {gps: {profile: px4_sitl, fix_type: 0}}\n")
    result = hil_run(str(scenario), "--px4", str(sitl), runs=tmp_path / "runs")
    assert result.returncode == 3, result.stdout + result.stderr
    ended = summary_field(result.stdout, "ended")
    assert "did not arm" in ended and "Arming denied" in ended
    assert not processes_using(tmp_path / "runs")


def test_two_sitl_runs_at_once_fly_on_different_instances(sitl, tmp_path):
    scenario = short_hover(tmp_path)
    runs = [subprocess.Popen([sys.executable, "-m", "hil", "run", "--no-report", str(scenario),
                              "--px4", str(sitl), "--runs", str(tmp_path / str(i)), "--no-telemetry"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT) for i in range(2)]
    outputs = [run.communicate(timeout=400) for run in runs]
    for run, (out, err) in zip(runs, outputs, strict=True):
        assert run.returncode == 0, out + err
    instances = {line.split("instance ")[1].split()[0] for out, _ in outputs for line in out.splitlines()
                 if line.startswith("board:")}
    assert len(instances) == 2, instances


class PhaseWatch:
    """Follows a run's phase over Zenoh (a real session on loopback) to interrupt it at a chosen moment."""

    def __init__(self, phase: str) -> None:
        self.endpoint = f"tcp/127.0.0.1:{free_port()}"
        self.reached = threading.Event()
        self._phase = phase
        self._sub = subscribe("hil/*/state", self._on_state, ZenohOptions(listen=[self.endpoint],
                                                                         multicast_scouting=False))

    def _on_state(self, _key: str, sample: dict[str, Any]) -> None:
        if sample.get("phase") == self._phase:
            self.reached.set()

    def wait_for(self, bench: subprocess.Popen[str], timeout_s: float = 120) -> None:
        """Until the run reaches the phase; a run that ended first, or is still short of it after `timeout_s`, fails
        the test with what it printed (in one clean CI run a flight never reached landing and nothing said why)."""
        deadline = time.monotonic() + timeout_s
        while not self.reached.wait(0.05):
            if bench.poll() is None and time.monotonic() < deadline:
                continue
            if bench.poll() is None:
                bench.send_signal(signal.SIGINT)
            out, err = bench.communicate(timeout=30)
            pytest.fail(f"the run never reached {self._phase} (exit {bench.returncode}):\n{out[-3000:]}\n{err[-3000:]}")

    def close(self) -> None:
        self._sub.close()


@pytest.mark.parametrize("phase,second_ctrl_c", [("preflight", False), ("takeoff", False), ("mission", False),
                                                 ("landing", False), ("landing", True)])
def test_ctrl_c_stops_the_run_and_px4_within_two_seconds(sitl, tmp_path, phase, second_ctrl_c):
    watch = PhaseWatch(phase)
    scenario = short_hover(tmp_path)
    try:
        bench = subprocess.Popen([sys.executable, "-m", "hil", "run", "--no-report", str(scenario),
                                  "--px4", str(sitl), "--runs", str(tmp_path / "runs"), "--zenoh-connect",
                                  watch.endpoint],
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
        watch.wait_for(bench)
    finally:
        watch.close()
    interrupted = time.monotonic()
    bench.send_signal(signal.SIGINT)
    if second_ctrl_c:  # a second Ctrl-C while the first one's shutdown runs
        time.sleep(0.1)
        bench.send_signal(signal.SIGINT)
    out, err = bench.communicate(timeout=30)
    assert bench.returncode == 130, out + err
    assert time.monotonic() - interrupted < 2.0
    run_dir = only_run_dir(tmp_path / "runs")
    assert not processes_using(run_dir)
    assert "interrupted" in (run_dir / "summary.txt").read_text()
    with open(run_dir / "recording.mcap", "rb") as f:
        reader = make_reader(f)
        assert reader.get_summary() is not None  # closed properly: the indexed reader opens it
        assert any(True for _ in reader.iter_messages(topics=["hil/state"]))


def test_px4_dying_mid_flight_ends_the_run_with_its_cause(sitl, tmp_path):
    watch = PhaseWatch("mission")
    scenario = short_hover(tmp_path)
    try:
        bench = subprocess.Popen([sys.executable, "-m", "hil", "run", "--no-report", str(scenario),
                                  "--px4", str(sitl), "--runs", str(tmp_path / "runs"), "--zenoh-connect",
                                  watch.endpoint],
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
        watch.wait_for(bench)
    finally:
        watch.close()
    run_dir = only_run_dir(tmp_path / "runs")
    daemon = [pid for pid, argv in live_processes().items()
              if argv[0].endswith("bin/px4") and str(run_dir / "px4") in argv]
    assert len(daemon) == 1, daemon
    os.kill(daemon[0], signal.SIGKILL)
    out, err = bench.communicate(timeout=30)
    assert bench.returncode == 3, out + err
    ended = summary_field(out, "ended")
    assert "PX4 was killed by signal 9" in ended
    assert not processes_using(run_dir)
    with open(run_dir / "recording.mcap", "rb") as f:
        assert make_reader(f).get_summary() is not None


LIBC = ctypes.CDLL(None, use_errno=True)  # tgkill(2): glibc 2.30 and later


def _process_group(group: int) -> list[int]:
    """The processes in process group `group` now."""
    pids = []
    for pid in [int(name) for name in os.listdir("/proc") if name.isdigit()]:
        with suppress(ProcessLookupError):
            if os.getpgid(pid) == group:
                pids.append(pid)
    return pids


def _running_threads(pid: int) -> list[str]:
    """`pid`'s threads that may still run its own code, as "tid comm state" (proc(5)). Stopped (T, t) or gone (Z, X)
    threads will not; nor will one in D: it is in the kernel and stops on its way out (at PX4's boot a thread waits
    there for a vfork child, itself stopped before its exec, until SIGCONT)."""
    running = []
    for task in Path(f"/proc/{pid}/task").glob("*"):
        with suppress(OSError):
            comm, rest = (task / "stat").read_text().rsplit(")", 1)
            if rest.split()[0] not in ("T", "t", "Z", "X", "D"):
                running.append(f"{task.name} {comm.split('(', 1)[1]} {rest.split()[0]}")
    return running


@dataclass
class Px4Stall:
    """A sink that stops PX4's whole process group (no CPU at all, as on a machine too busy for it) at the first
    step `at_s` of simulated time past its first lockstep reply (None: at the first step, before any reply) for
    `stall_s` (None: for good), and ends the run as Ctrl-C would once it has flown `fly_on_s` past the stall (None:
    the run goes on until something else ends it)."""

    runs: Path
    at_s: float | None
    stall_s: float | None
    fly_on_s: float | None = None
    frames: list[StepFrame] = field(default_factory=list)
    first_reply_us: int | None = None
    stalled_us: int | None = None
    resume: threading.Timer | None = None

    def __call__(self, frame: StepFrame) -> None:
        self.frames.append(frame)
        if self.first_reply_us is None and frame.round_trip_s is not None:  # the step was answered in lockstep
            self.first_reply_us = frame.t_us
        if self.stalled_us is None:
            if self.at_s is None or (self.first_reply_us is not None
                                     and frame.t_us - self.first_reply_us >= self.at_s * 1e6):
                self._stop(frame.t_us)
        elif self.fly_on_s is not None and frame.t_us - self.stalled_us >= self.fly_on_s * 1e6:
            raise KeyboardInterrupt("the test flew far enough")

    def _stop(self, t_us: int) -> None:
        (daemon,) = [pid for pid, argv in live_processes().items()
                     if argv[0].endswith("bin/px4") and str(self.runs.resolve()) in " ".join(argv)]
        os.killpg(daemon, signal.SIGSTOP)
        # the stop lands as each thread is next scheduled: on a loaded machine PX4 answered two more steps after
        # killpg returned (one clean CI run). The bench sends its next step only once this sink returns
        deadline = time.monotonic() + 5.0
        while running := [thread for pid in _process_group(daemon) for thread in _running_threads(pid)]:
            assert time.monotonic() < deadline, f"PX4 did not stop within 5 s of SIGSTOP: {running}"
            time.sleep(0.001)
        self.stalled_us = t_us
        if self.stall_s is not None:
            self.resume = threading.Timer(self.stall_s, self._continue, (daemon,))
            self.resume.start()

    @staticmethod
    def _continue(daemon: int) -> None:
        """SIGCONT to each process of the group at its main thread (tgkill), which continues all its threads. Sent to
        the process, the kernel may run the handler PX4 installs for SIGCONT (hrt_thread.c) on any thread: on its
        daemon socket's thread, poll() fails with EINTR, that thread ends and unlinks /tmp/px4-sock-N, and the start-up
        script's next client fails ("error connecting to socket", PX4 exits 255): twice in this test's clean CI runs."""
        for pid in _process_group(daemon):
            with suppress(ProcessLookupError):  # the run may have ended and stopped PX4 meanwhile
                if LIBC.tgkill(pid, pid, signal.SIGCONT) != 0:
                    raise OSError(ctypes.get_errno(), f"tgkill {pid} SIGCONT")  # ESRCH: ProcessLookupError

    def fly(self, sitl: Path, scenario: Path, connect_timeout_s: float | None = None) -> RunOutcome:
        board = Px4SitlTarget(Px4Build.locate(sitl, "--px4"), connect_timeout_s)
        try:
            return run_scenario(load_scenario(scenario), RunOptions(board=board, runs_root=self.runs, telemetry=None,
                                                                    gcs=[]), sinks=[FrameSink(self)])
        finally:
            if self.resume is not None:
                self.resume.join()


STALL_S = 1.5  # longer than the link watchdog's 1 s


def test_px4_stalled_in_its_boot_is_waited_for(sitl, tmp_path):
    """PX4 SITL starts its modules beside the first steps; on a starved machine it (and the bench's own set-up) took
    over 1 s, and the 1 s watchdog ended the run. A stall right after PX4's first lockstep reply is waited for: until
    its replies span BOOT_US of simulated time the limit is its start timeout. The run flies on past its boot."""
    stall = Px4Stall(tmp_path / "runs", at_s=0.0, stall_s=STALL_S, fly_on_s=BOOT_US / 1e6 + 0.5)
    outcome = stall.fly(sitl, short_hover(tmp_path))
    assert (outcome.exit_code, outcome.reason) == (EXIT_INTERRUPTED, "interrupted (the test flew far enough)")
    assert max(f.step_wall_s for f in stall.frames) > 1.2  # the bench really waited out a silence over the watchdog


def test_the_same_stall_after_px4s_boot_trips_the_watchdog(sitl, tmp_path):
    stall = Px4Stall(tmp_path / "runs", at_s=BOOT_US / 1e6 + 0.2, stall_s=STALL_S)
    outcome = stall.fly(sitl, short_hover(tmp_path))
    assert outcome.exit_code == EXIT_BOARD, outcome.reason
    assert "board silent for" in outcome.reason and "(watchdog 1.00 s)" in outcome.reason
    assert "PX4's console ends: " in outcome.reason and str(outcome.run_dir / "px4.log") in outcome.reason
    assert stall.stalled_us is not None and stall.frames[-1].t_us - stall.stalled_us <= 8000  # it ended there
    assert not processes_using(tmp_path / "runs")


def test_px4_that_never_answers_ends_the_run_after_its_start_timeout_leaving_nothing_behind(sitl, tmp_path):
    never = Px4Stall(tmp_path / "runs", at_s=None, stall_s=None)
    outcome = never.fly(sitl, short_hover(tmp_path), connect_timeout_s=3.0)
    assert outcome.exit_code == EXIT_BOARD, outcome.reason
    assert "board silent for" in outcome.reason and "while it boots (allowed 3 s, its start timeout" in outcome.reason
    assert never.first_reply_us is None  # stopped before its first reply, it never answered
    assert not processes_using(tmp_path / "runs")
    assert "while it boots" in summary_field((outcome.run_dir / "summary.txt").read_text(), "ended")
