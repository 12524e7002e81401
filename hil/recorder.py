"""The run directory: scenario as resolved, meta, a full-rate MCAP recording, metrics and summary.

Written incrementally: the MCAP writer emits small chunks and the file is flushed with each, so a
crash leaves everything up to the last chunk readable (mcap's StreamReader reads a file without its
summary section); a normal end, Ctrl-C or a lost link close the file properly.
"""

from __future__ import annotations

import json
import platform
import subprocess
from datetime import datetime, timezone
from importlib import metadata
from pathlib import Path
from typing import Any

import orjson
import yaml
from mcap.writer import CompressionType, Writer

from hil.frame import StepFrame
from plant_fmu.plant import REAL_OUTPUT_NAMES

CHANNELS = ("state", "reference", "sensors/imu", "sensors/gps", "sensors/baro", "sensors/mag", "actuators",
            "environment", "board", "timing", "events")
_OUT = {n: i for i, n in enumerate(REAL_OUTPUT_NAMES)}
_JSON_OPTIONS = orjson.OPT_SERIALIZE_NUMPY


def _vec(out: Any, *names: str) -> list[float]:
    return [float(out[_OUT[n]]) for n in names]


def frame_messages(frame: StepFrame) -> list[tuple[str, dict[str, Any]]]:
    """The channel messages of one step (the same payloads go to the recording and to telemetry), built
    once per frame whichever sink asks first."""
    if frame.messages is None:
        frame.messages = _build_messages(frame)
    return frame.messages


def _build_messages(frame: StepFrame) -> list[tuple[str, dict[str, Any]]]:
    out, t = frame.truth, frame.t_us
    messages: list[tuple[str, dict[str, Any]]] = [
        ("state", {"t_us": t, "pos_ned": _vec(out, "pos_n", "pos_e", "pos_d"),
                   "vel_ned": _vec(out, "vel_n", "vel_e", "vel_d"), "q_wxyz": _vec(out, "q_w", "q_x", "q_y", "q_z"),
                   "rpy": _vec(out, "roll", "pitch", "yaw"), "rates_frd": _vec(out, "rate_x", "rate_y", "rate_z"),
                   "thrust_total": float(out[_OUT["thrust_total"]]), "total_mass": float(out[_OUT["total_mass"]]),
                   "on_ground": frame.on_ground, "phase": frame.phase, "mission_t": frame.mission_t}),
        ("sensors/imu", {"t_us": t, "accel_frd": frame.readings.accel_frd, "gyro_frd": frame.readings.gyro_frd}),
        ("actuators", {"t_us": t, "motors": frame.motors, "armed": frame.armed}),
        ("environment", {"t_us": t, "wind_ned": frame.environment.wind_ned, "force_ned": frame.environment.force_ned,
                         "torque_frd": frame.environment.torque_frd, "payload_kg": frame.environment.payload_kg,
                         "motor_health": frame.environment.motor_health}),
        ("timing", {"t_us": t, "step_wall_us": frame.step_wall_s * 1e6,
                    "round_trip_us": None if frame.round_trip_s is None else frame.round_trip_s * 1e6}),
    ]
    if frame.reference is not None:
        r = frame.reference
        messages.append(("reference", {"t_us": t, "pos_ned": r.pos_ned, "vel_ned": r.vel_ned, "acc_ned": r.acc_ned,
                                       "yaw": r.yaw}))
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
        messages.append(("board", {"t_us": t, "message": kind, **payload}))
    return messages


def make_run_dir(root: Path, scenario_name: str) -> Path:
    stamp = datetime.now(timezone.utc).strftime("%Y%m%dT%H%M%S.%fZ")
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

    def __init__(self, run_dir: Path, resolved_scenario: dict[str, Any], meta: dict[str, Any]) -> None:
        self.dir = run_dir
        (run_dir / "scenario.yaml").write_text(yaml.safe_dump(resolved_scenario, sort_keys=False))
        versions = {p: _version(p) for p in ("hil-bench", "fmpy", "pymavlink", "numpy", "eclipse-zenoh")}
        meta = {**meta, "versions": {**versions, "python": platform.python_version()}, "git_revision": git_revision()}
        (run_dir / "meta.json").write_text(json.dumps(meta, indent=2, default=str))
        self._file = open(run_dir / "recording.mcap", "wb")  # noqa: SIM115 - closed in close()
        self._writer = Writer(self._file, chunk_size=64 * 1024, compression=CompressionType.ZSTD)
        self._writer.start(profile="", library="hil-bench")
        schema = self._writer.register_schema("hil.Sample", "jsonschema", b'{"type": "object"}')
        self._channels = {name: self._writer.register_channel(f"hil/{name}", "json", schema) for name in CHANNELS}
        self._last_flush_bytes = 0
        self.closed = False

    def record(self, frame: StepFrame) -> None:
        self.write_messages(frame.t_us, frame_messages(frame))

    def write_messages(self, t_us: int, messages: list[tuple[str, dict[str, Any]]]) -> None:
        stamp = t_us * 1000
        add, channels = self._writer.add_message, self._channels
        for channel, payload in messages:
            add(channels[channel], stamp, orjson.dumps(payload, option=_JSON_OPTIONS), stamp)
        position = self._file.tell()
        if position != self._last_flush_bytes:  # a chunk went out: push it to disk
            self._file.flush()
            self._last_flush_bytes = position

    def event(self, t_us: int, text: str) -> None:
        self.write_messages(t_us, [("events", {"t_us": t_us, "text": text})])

    def finish(self, metrics: dict[str, Any], summary: str) -> None:
        if not self.closed:
            self.closed = True
            self._writer.finish()
            self._file.close()
        (self.dir / "metrics.json").write_text(json.dumps(metrics, indent=2, default=float))
        (self.dir / "summary.txt").write_text(summary)
