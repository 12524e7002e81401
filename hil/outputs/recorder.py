"""The run directory: scenario as resolved, meta, a full-rate MCAP recording, metrics and summary.

The recording has one JSON channel per sample type, each with its own JSON Schema (`hil.channels`),
beside Foxglove's well-known messages (`hil.outputs.foxglove_messages`); the resolved scenario, the run meta
and the final metrics are MCAP metadata records. Log times are the wall-clock start of the run plus
simulated time, so a viewer shows the real date; every sample keeps its simulated `t_us`.

Written incrementally by foxglove-sdk's MCAP writer (Rust: ~1 us a message where the pure-Python `mcap`
writer took ~3-6 us, and ~17 messages go out each step): it writes each 1 MiB chunk to the file as it
closes it, so a crash leaves everything up to the last chunk readable (`hil recover` rebuilds the index);
a normal end, Ctrl-C or a lost link close the file properly. Chunks are LZ4-compressed: the writer holds
the interpreter while it compresses, 6-10 ms a chunk with zstd (every other thread, the stepping one
included, stood still that long: late steps in a paced run) and under 2 ms with LZ4, for files ~1.5x
larger (measured on a 75 s HITL rehearsal: 8.6 MB zstd, 12.8 MB LZ4).

In a paced run (`background`) the MCAP writing runs on its own thread, fed in order through a
bounded queue, so that serialising and closing chunks never sits between a step's deadline and its
sensor frame (with the earlier Python writer, closing a chunk on the stepping thread made a board paced
on the wall clock see a late sensor frame every ~2.5 s). A lockstep run writes on the stepping thread,
after the step's frame is sent (there a second thread only competes for the interpreter: -6 % real-time
factor, measured).
"""

from __future__ import annotations

import json
import os
import platform
import queue
import subprocess
import sys
import threading
import time
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path
from typing import Any

import foxglove
import orjson
import yaml
from foxglove.mcap import MCAPCompression, MCAPWriteOptions

from firmware_interface.geodesy import LocalFrame
from hil.channels import BOARD_CHANNEL, RECORDED_CHANNELS
from hil.host.rt_priority import current_fifo_priority, run_just_below
from hil.host.stop_signals import uninterrupted
from hil.loop.frame import StepFrame
from hil.loop.sink import Outcome
from hil.outputs.context import OutputContext
from hil.outputs.disk import DiskWatch, partial_record_start
from hil.outputs.foxglove_channels import byte_loggers, json_channels, view_channels
from hil.outputs.foxglove_messages import FoxgloveViews

# The writer keeps an index entry per chunk in memory until the file's summary is written: 1 MiB chunks
# (about 2.3 s of simulated time at 250 Hz, all channels: ~440 KiB/s) keep that under ~5 MB for a 2-hour run, and
# are what a crash can lose (the last, unfinished chunk).
CHUNK_BYTES = 1024 * 1024
QUEUE_STEPS = 1000  # steps the writer thread may lag behind (4 s at 250 Hz); then the stepping thread waits
# The writer thread gives the interpreter back at least this often when the stepping thread wants it
# (Python's default is 5 ms, longer than a step): what a paced step waits at most for the GIL.
SWITCH_INTERVAL_S = 100e-6
_JSON_OPTIONS = orjson.OPT_SERIALIZE_NUMPY


def frame_messages(frame: StepFrame) -> list[tuple[str, dict[str, Any]]]:
    """The channel messages of one step (the same payloads go to the recording and to telemetry), built
    once per frame whichever sink asks first."""
    if frame.messages is None:
        frame.messages = _build_messages(frame)
    return frame.messages


def _build_messages(frame: StepFrame) -> list[tuple[str, dict[str, Any]]]:
    """The vectors go in as lists: orjson writes a 3-vector from a list in about half the time it takes from an
    array (the same text)."""
    s, t, e = frame.truth, frame.t_us, frame.environment
    messages: list[tuple[str, dict[str, Any]]] = [
        ("state", {"t_us": t, "pos_ned": s.pos_ned.tolist(), "vel_ned": s.vel_ned.tolist(),
                   "acc_ned": s.acc_ned.tolist(), "q_wxyz": s.q_wxyz.tolist(), "rpy": s.rpy.tolist(),
                   "rates_frd": s.rates_frd.tolist(), "thrust_total": s.thrust_total_n, "total_mass": s.total_mass_kg,
                   "on_ground": s.on_ground, "phase": frame.phase, "mission_t": frame.mission_t}),
        ("sensors/imu", {"t_us": t, "accel_frd": frame.readings.accel_frd, "gyro_frd": frame.readings.gyro_frd}),
        ("actuators", {"t_us": t, "motors": frame.motors, "armed": frame.armed}),
        ("environment", {"t_us": t, "wind_ned": e.wind_ned.tolist(), "force_ned": e.force_ned.tolist(),
                         "torque_frd": e.torque_frd.tolist(), "payload_kg": e.payload_kg,
                         "motor_health": e.motor_health}),
        ("timing", {"t_us": t, "step_wall_us": frame.step_wall_s * 1e6,
                    "round_trip_us": None if frame.round_trip_s is None else frame.round_trip_s * 1e6,
                    "start_monotonic_us": round(frame.started_s * 1e6)}),
    ]
    if frame.reference is not None:
        r = frame.reference
        messages.append(("reference", {"t_us": t, "pos_ned": r.pos_ned.tolist(), "vel_ned": r.vel_ned.tolist(),
                                       "acc_ned": r.acc_ned.tolist(), "yaw": r.yaw}))
    if frame.readings.mag_frd_t is not None:
        messages.append(("sensors/mag", {"t_us": t, "mag_frd_t": frame.readings.mag_frd_t}))
    if frame.readings.baro is not None:
        b = frame.readings.baro
        messages.append(("sensors/baro", {"t_us": t, "pressure_pa": b.pressure_pa,
                                          "temperature_degc": b.temperature_degc, "pressure_alt_m": b.pressure_alt_m}))
    if frame.gps is not None:
        g = frame.gps
        messages.append(("sensors/gps", {"t_us": t, "measured_t_us": g.t_us, "lat_deg": g.lat_deg, "lon_deg": g.lon_deg,
                                         "alt_msl_m": g.alt_msl_m, "vel_ned": g.vel_ned, "eph_m": g.eph_m,
                                         "epv_m": g.epv_m, "fix_type": g.fix_type, "satellites": g.satellites}))
    for kind, payload in frame.board:
        messages.append((BOARD_CHANNEL[kind], {"t_us": t, **payload}))
    for channel, payload in frame.sent:
        messages.append((channel, {"t_us": t, **payload}))
    return messages


def make_run_dir(root: Path, scenario_name: str) -> Path:
    stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%S.%fZ")
    path = root / f"{stamp}-{scenario_name}"
    path.mkdir(parents=True, exist_ok=False)
    return path


def _version(package: str) -> str:
    try:
        return metadata.version(package)
    except metadata.PackageNotFoundError:
        return "unknown"


def git_revision() -> str:
    try:
        result = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True, timeout=5,
                                cwd=Path(__file__).resolve().parent)
        return result.stdout.strip() or "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


class Recorder:
    """Owns the run directory of one run."""

    def __init__(self, run_dir: Path, resolved_scenario: dict[str, Any], meta: dict[str, Any],
                 local_frame: LocalFrame, scene: Any = None, start_ns: int | None = None,
                 background: bool = False, disk: DiskWatch | None = None) -> None:
        self.dir = run_dir
        self.start_ns = time.time_ns() if start_ns is None else start_ns
        self.disk = DiskWatch(run_dir) if disk is None else disk  # its reserve, the watch on the writer's errors
        scenario_text = yaml.safe_dump(resolved_scenario, sort_keys=False)
        (run_dir / "scenario.yaml").write_text(scenario_text)
        versions = {p: _version(p) for p in ("hil-bench", "fmpy", "pymavlink", "numpy", "eclipse-zenoh")}
        meta = {**meta, "versions": {**versions, "python": platform.python_version()}, "git_revision": git_revision(),
                "start_unix_ns": self.start_ns}
        meta_text = json.dumps(meta, indent=2, default=str)
        (run_dir / "meta.json").write_text(meta_text)
        self._context = foxglove.Context()  # the recording's own: the live server logs in another
        self._path = run_dir / "recording.mcap"
        self._writer: Any = foxglove.open_mcap(self._path, context=self._context,
                                          writer_options=MCAPWriteOptions(chunk_size=CHUNK_BYTES, profile="",
                                                                          compression=MCAPCompression.Lz4))
        self._writer.write_metadata("scenario", {"yaml": scenario_text})
        self._writer.write_metadata("run", {"json": meta_text})
        self._channels = byte_loggers(json_channels(self._context, RECORDED_CHANNELS))
        self._foxglove = byte_loggers(view_channels(self._context))
        self._views = FoxgloveViews(local_frame, self.start_ns)
        self.closed = False
        if scene is not None:
            with uninterrupted():
                self._foxglove["foxglove/scene"](scene.encode(), self.start_ns)
        self._queue: queue.Queue[tuple[int, list[tuple[str, dict[str, Any]]]] | None] = queue.Queue(QUEUE_STEPS)
        self._failure: BaseException | None = None  # what stopped the writer thread, raised on the next write
        self._thread: threading.Thread | None = None  # started by the first write (see `write_messages`)
        self.background = background  # write on the writer thread (a run paced on the wall clock)

    def on_step(self, frame: StepFrame) -> None:
        self.write_messages(frame.t_us, frame_messages(frame))

    def write_messages(self, t_us: int, messages: list[tuple[str, dict[str, Any]]]) -> None:
        """Write one step's messages, or queue them for the writer thread (in call order either way); DiskFull
        once a write of the run has failed for lack of space, and from then on nothing is written."""
        if self.disk.failure is not None:
            self.disk.check()
            return
        if self._failure is not None:
            raise OSError(f"writing {self.dir / 'recording.mcap'} failed: {self._failure}") from self._failure
        if not self.background:
            with uninterrupted():  # a stop signal here would record half a step
                self._write(t_us, messages)
            return
        if self._thread is None:
            self._start_thread()
        self._queue.put((t_us, messages))

    def _start_thread(self) -> None:
        """Started from the stepping thread once it flies, at one real-time priority below it when it has
        one (`run_just_below`): as an ordinary thread the writer, holding the interpreter, was kept off the
        CPU by PX4's threads while the step waited for it (a priority inversion: 6-8 ms stalls)."""
        self._switch_interval_s = sys.getswitchinterval()  # restored at finish: a later lockstep run keeps 5 ms
        sys.setswitchinterval(min(self._switch_interval_s, SWITCH_INTERVAL_S))
        self._thread = threading.Thread(target=self._write_queued, args=(current_fifo_priority(),),
                                        name="mcap-writer", daemon=True)
        self._thread.start()

    def _write_queued(self, stepping_priority: int) -> None:
        """The writer thread: stop signals land on the main thread, so no record here is cut in half."""
        run_just_below(stepping_priority)
        try:
            while (item := self._queue.get()) is not None:
                self._write(*item)
        except BaseException as exc:  # kept and raised on the stepping thread
            self._failure = exc
            while self._queue.get() is not None:  # unblock the stepping thread until finish()
                pass

    def _write(self, t_us: int, messages: list[tuple[str, dict[str, Any]]]) -> None:
        stamp = self.start_ns + t_us * 1000
        channels, views = self._channels, self._foxglove
        for channel, payload in messages:
            channels[channel](orjson.dumps(payload, option=_JSON_OPTIONS), stamp)
        for topic, message in self._views.messages(messages):
            views[topic](message.encode(), stamp)

    def on_event(self, t_us: int, text: str) -> None:
        self.write_messages(t_us, [("events", {"t_us": t_us, "text": text})])

    def close(self, outcome: Outcome) -> None:
        """Metrics and summary first (in the room the disk watch kept), then the recording's end: a stop signal
        that arrives meanwhile waits for the queued steps and the file's summary, and is raised once everything
        is on disk. On a full disk what cannot be written is skipped; the recording stays recoverable."""
        self.disk.release()
        metrics_text = json.dumps(outcome.metrics, indent=2, default=float)
        summary = outcome.summary
        self.disk.attempt("metrics.json", lambda: (self.dir / "metrics.json").write_text(metrics_text))
        self.disk.attempt("summary.txt", lambda: (self.dir / "summary.txt").write_text(summary))
        if self.closed:
            return
        self.closed = True
        with uninterrupted():
            if self._thread is not None:
                self._queue.put(None)
                self._thread.join()
                sys.setswitchinterval(self._switch_interval_s)
            cut_at = partial_record_start(self._path) if self.disk.failure is not None else None
            try:
                self._writer.write_metadata("metrics", {"json": metrics_text, "summary": summary})
                self._writer.close()
            except RuntimeError:  # foxglove's FoxgloveError: the file could not be finished (what the watch saw)
                self.disk.failed("recording.mcap")
            finally:
                self._writer = None  # dropped now, while Python runs: at exit its error log would panic
                if cut_at is not None:  # what a failed write left half-written, and all the close put after it
                    os.truncate(self._path, cut_at)
                self.disk.close()


def open_output(context: OutputContext) -> Recorder:
    """The run directory's files and the recording: always. A paced run writes on a thread of its own, so that a
    chunk's compression never delays a step."""
    return Recorder(context.run_dir, context.resolved_scenario, context.meta, context.local_frame, context.scene,
                    context.start_ns, background=context.paced, disk=context.disk)
