"""A run directory read back: the recording as arrays on the mission clock, with the resolved scenario, meta,
metrics and summary beside it. `load_flight` keeps every phase (the HTML report); `load_run` keeps the mission
(the paper's figures and the comparisons)."""

from __future__ import annotations

import gc
import json
import math
import mmap
import struct
from collections import defaultdict
from collections.abc import Collection, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from itertools import pairwise
from pathlib import Path
from typing import Any

import lz4.frame
import numpy as np
import orjson
import yaml
import zstandard
from mcap.opcode import Opcode

from firmware_interface.emulator.geometry import quat_to_euler
from firmware_interface.geodesy import STANDARD_GRAVITY_M_S2
from hil.channels import BOARD_CHANNEL, TOPIC_PREFIX

G_NED_M_S2 = np.array([0.0, 0.0, STANDARD_GRAVITY_M_S2])
# what the reports read (the IMU, magnetometer and barometer channels are most of a recording and unused)
REPORT_CHANNELS = ("state", "reference", "environment", "actuators", "timing", "events", "sensors/gps",
                   "board/attitude_target", "board/estimates", "board/local_position_ned", "board/attitude", "battery",
                   "manual_control")
_MAGIC = b"\x89MCAP0\r\n"
_HEADER, _U16, _U32, _U64 = struct.Struct("<BQ"), struct.Struct("<H"), struct.Struct("<I"), struct.Struct("<Q")


class NoFlightData(ValueError):
    """A run directory whose recording holds no mission-phase state: there is nothing to draw."""


class BadRunFile(ValueError):
    """A file of the run directory that cannot be read back (cut short by a full disk, edited by hand)."""


def rpy_from_quaternion(q_wxyz: np.ndarray) -> np.ndarray:
    """ZYX Euler angles (roll, pitch, yaw, rad) of FRD in NED from quaternions (N, 4), scalar first."""
    return np.array([quat_to_euler(q) for q in np.asarray(q_wxyz, dtype=float).reshape(-1, 4)]).reshape(-1, 3)


def disturbance_ned(acc_ned: np.ndarray, q_wxyz: np.ndarray, thrust_total_n: np.ndarray,
                    mass_kg: np.ndarray) -> np.ndarray:
    """The total force on the vehicle that is neither rotor thrust nor gravity, NED, N (drag, rotor
    aerodynamics, gusts, scripted forces): m·a = R(q)·(0, 0, −T) + m·g + d solved for d, from the true state.
    A wind scenario scripts no force, so this, not the environment's force_ned, is what the wind did."""
    w, x, y, z = np.asarray(q_wxyz, dtype=float).reshape(-1, 4).T
    body_down_ned = np.column_stack((2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)))
    acc = np.asarray(acc_ned, dtype=float).reshape(-1, 3)
    mass = np.asarray(mass_kg, dtype=float).reshape(-1, 1)
    return mass * (acc - G_NED_M_S2) + np.asarray(thrust_total_n, dtype=float).reshape(-1, 1) * body_down_ned


def _chunk_content(buffer: bytes | mmap.mmap, body: int) -> bytes:
    """The records inside a Chunk record (start, end u64, uncompressed size u64, crc u32, compression, records)."""
    size = _U64.unpack_from(buffer, body + 16)[0]
    name_length = _U32.unpack_from(buffer, body + 28)[0]
    compression = bytes(buffer[body + 32:body + 32 + name_length]).decode()
    at = body + 32 + name_length
    data = buffer[at + 8:at + 8 + _U64.unpack_from(buffer, at)[0]]
    if compression == "zstd":
        return zstandard.decompress(data, size)
    return lz4.frame.decompress(data) if compression == "lz4" else bytes(data)


def _scan(records: bytes | mmap.mmap, start: int, wanted: set[str], raw: dict[int, tuple[str, list[bytes]]]) -> None:
    """Collects the data of the wanted topics' Message records, by channel id, reading the records in place (mcap's
    reader builds an object per record and per message-index entry: four times slower on a bench recording, some
    200 000 records a minute of flight). Stops at a record cut short, as a crash leaves the file."""
    position, end = start, len(records)
    while position + _HEADER.size <= end:
        opcode, length = _HEADER.unpack_from(records, position)
        body = position + _HEADER.size
        if body + length > end or opcode in (Opcode.DATA_END, Opcode.FOOTER):
            return
        if opcode == Opcode.MESSAGE:  # channel id u16, sequence u32, log time u64, publish time u64, data
            sink = raw.get(_U16.unpack_from(records, body)[0])
            if sink is not None:
                sink[1].append(records[body + 22:body + length])
        elif opcode == Opcode.CHANNEL:  # id u16, schema id u16, topic (u32 length, UTF-8), ...
            size = _U32.unpack_from(records, body + 4)[0]
            topic = bytes(records[body + 8:body + 8 + size]).decode()
            if topic in wanted:
                raw.setdefault(_U16.unpack_from(records, body)[0], (topic, []))
        elif opcode == Opcode.CHUNK:
            _scan(_chunk_content(records, body), 0, wanted, raw)
        position = body + length


@contextmanager
def _collector_paused() -> Iterator[None]:
    """Parsed samples hold no reference cycles; the cyclic collector's passes over the ~150 000 dicts of a minute
    of flight, as they are made, took half the time of reading them."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


def read_channels(path: Path, channels: Collection[str] = REPORT_CHANNELS) -> dict[str, list[dict[str, Any]]]:
    """The JSON samples of the named channels (topic without "hil/"), in log order; other topics (Foxglove's
    protobuf ones) are not decoded. A recording cut short by a crash is read up to its last whole chunk.
    Recordings from before one topic per board message (`hil/board` with a `message` field) read the same."""
    raw: dict[int, tuple[str, list[bytes]]] = {}
    with open(path, "rb") as f:
        if f.read(len(_MAGIC)) != _MAGIC:
            return {}
        with mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as buffer:
            _scan(buffer, len(_MAGIC), {TOPIC_PREFIX + c for c in (*channels, "board")}, raw)
    out: dict[str, list[dict[str, Any]]] = defaultdict(list)
    with _collector_paused():
        for topic, data in raw.values():
            out[topic[len(TOPIC_PREFIX):]].extend(map(orjson.loads, data))
    for sample in out.pop("board", []):
        out[BOARD_CHANNEL.get(sample.pop("message", ""), "board")].append(sample)
    return dict(out)


def _no_flight_data(run_dir: Path, what: str) -> NoFlightData:
    try:
        reason = _json(run_dir / "metrics.json").get("reason")
    except BadRunFile:
        reason = None
    ended = f" (the run ended: {' '.join(str(reason).split())})" if reason else ""
    return NoFlightData(f"{run_dir}: no flight data to report: {what}{ended}")


def _json(path: Path) -> dict[str, Any]:
    """The file's JSON object ({} without the file), or BadRunFile."""
    if not path.is_file():
        return {}
    try:
        data = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise BadRunFile(f"{path}: not valid JSON, cut short? ({exc})") from None
    if not isinstance(data, dict):
        raise BadRunFile(f"{path}: expected a JSON object, found {type(data).__name__}")
    return data


def _scenario(path: Path) -> dict[str, Any]:
    """The run's resolved scenario ({} without the file), or BadRunFile."""
    if not path.is_file():
        return {}
    try:
        data = yaml.safe_load(path.read_text())
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as exc:
        raise BadRunFile(f"{path}: cannot be read as YAML ({str(exc).splitlines()[0]})") from None
    return data if isinstance(data, dict) else {}


@dataclass
class Flight:
    """A whole run as recorded, every phase, with the run directory's files; times on the mission clock
    (s, 0 when the mission starts, negative before), the clock the scenario's gusts and faults are timed on."""

    run_dir: Path
    scenario: dict[str, Any]
    meta: dict[str, Any]
    metrics: dict[str, Any]
    summary: str
    channels: dict[str, list[dict[str, Any]]]
    mission_start_us: float  # bench time of mission time 0

    def samples(self, channel: str) -> list[dict[str, Any]]:
        return self.channels.get(channel, [])

    def time(self, channel: str) -> np.ndarray:
        """Mission time of each sample of the channel, s."""
        return (np.array([s["t_us"] for s in self.samples(channel)], dtype=float) - self.mission_start_us) * 1e-6

    def column(self, channel: str, key: str) -> np.ndarray:
        """One field of every sample as floats (a missing or null value is NaN); vectors give (N, k)."""
        values = [s.get(key) for s in self.samples(channel)]
        width = next((len(v) for v in values if isinstance(v, list)), 0)
        blank = [np.nan] * width if width else np.nan
        return np.array([blank if v is None else v for v in values], dtype=float)

    def true_disturbance_ned(self) -> np.ndarray:
        """`disturbance_ned` of every state sample; recordings without `acc_ned` differentiate the velocity."""
        acc = self.column("state", "acc_ned")
        if acc.ndim != 2:
            acc = np.gradient(self.column("state", "vel_ned"), self.time("state"), axis=0)
        return disturbance_ned(acc, self.column("state", "q_wxyz"), self.column("state", "thrust_total"),
                               self.column("state", "total_mass"))


def load_flight(run_dir: Path, channels: Collection[str] = REPORT_CHANNELS) -> Flight:
    """The run directory read back; raises NoFlightData when the recording is missing, empty or holds no
    mission (a board that never connected, a take-off that failed)."""
    recording = run_dir / "recording.mcap"
    if not recording.is_file() or recording.stat().st_size == 0:
        raise _no_flight_data(run_dir, f"{recording.name} is {'empty' if recording.is_file() else 'missing'}")
    data = read_channels(recording, channels)
    first = next((s for s in data.get("state", []) if s["phase"] == "mission"), None)
    if first is None:
        raise _no_flight_data(run_dir, "the recording has no mission-phase state samples")
    scenario_path, summary_path = run_dir / "scenario.yaml", run_dir / "summary.txt"
    return Flight(run_dir=run_dir, scenario=_scenario(scenario_path),
                  meta=_json(run_dir / "meta.json"), metrics=_json(run_dir / "metrics.json"),
                  summary=summary_path.read_text() if summary_path.is_file() else "", channels=data,
                  mission_start_us=first["t_us"] - first["mission_t"] * 1e6)


@dataclass
class RunData:
    name: str
    controller: str
    t: np.ndarray  # mission time of each step
    pos: np.ndarray
    ref: np.ndarray
    rpy: np.ndarray
    mass: np.ndarray  # true total mass
    force: np.ndarray  # applied disturbance force, NED
    cmd_t: np.ndarray  # times of the board's commanded attitudes
    cmd_rpy: np.ndarray
    est_t: np.ndarray  # times of the board's estimates
    estimates: dict[str, np.ndarray]
    metrics: dict

    @property
    def error(self) -> np.ndarray:
        return self.pos - self.ref


def _in_mission(flight: Flight, channel: str, first_us: int, last_us: int) -> tuple[np.ndarray, list[dict]]:
    samples = [s for s in flight.samples(channel) if first_us <= s["t_us"] <= last_us]
    return np.array([s["t_us"] - flight.mission_start_us for s in samples]) * 1e-6, samples


_NO_REFERENCE = (math.nan, math.nan, math.nan)  # a step without a setpoint (a board flying its own mission)


def load_run(run_dir: Path) -> RunData:
    """The mission phase of a run (raises NoFlightData without one)."""
    flight = load_flight(run_dir, ("state", "reference", "environment", "board/attitude_target", "board/estimates"))
    states = [s for s in flight.samples("state") if s["phase"] == "mission"]
    steps = {s["t_us"] for s in states}
    refs = {s["t_us"]: s["pos_ned"] for s in flight.samples("reference") if s["t_us"] in steps}
    envs = {s["t_us"]: s["force_ned"] for s in flight.samples("environment") if s["t_us"] in steps}
    first, last = states[0]["t_us"], states[-1]["t_us"]
    cmd_t, cmd = _in_mission(flight, "board/attitude_target", first, last)
    est_t, est = _in_mission(flight, "board/estimates", first, last)
    keys = sorted({k for s in est for k in s["values"]})
    return RunData(
        name=flight.scenario["name"], controller=flight.scenario["board"]["controller"],
        t=np.array([s["mission_t"] for s in states]),
        pos=np.array([s["pos_ned"] for s in states]).reshape(-1, 3),
        ref=np.array([refs.get(s["t_us"], _NO_REFERENCE) for s in states]).reshape(-1, 3),  # NaN: a board's own
        rpy=np.array([s["rpy"] for s in states]).reshape(-1, 3),
        mass=np.array([s["total_mass"] for s in states]),
        force=np.array([envs[s["t_us"]] for s in states]).reshape(-1, 3),
        cmd_t=cmd_t, cmd_rpy=rpy_from_quaternion(np.array([s["q"] for s in cmd]).reshape(-1, 4)),
        est_t=est_t, estimates={k: np.array([s["values"].get(k, np.nan) for s in est]) for k in keys},
        metrics=flight.metrics,
    )


def recovery_times(data: RunData, step_times: list[float], floor_m: float = 0.05,
                   before_s: float = 2.0) -> list[float | None]:
    """Seconds after each payload step until |e_z| is back for good (within the step's window) inside the
    band the vehicle held before the first step: max(floor_m, 3 × RMS of e_z over the `before_s` before
    it), so noisy sensors do not make every recovery look endless."""
    out: list[float | None] = []
    if not step_times:
        return out
    bounds = [*step_times, float(data.t[-1]) + 1e-9]
    before = (data.t >= step_times[0] - before_s) & (data.t < step_times[0])
    band = max(floor_m, 3 * float(np.sqrt(np.mean(data.error[before, 2] ** 2)))) if before.any() else floor_m
    for start, end in pairwise(bounds):
        window = (data.t >= start) & (data.t < end)
        e = np.abs(data.error[window, 2])
        outside = np.flatnonzero(e >= band)
        if len(outside) == 0:
            out.append(0.0)
        elif outside[-1] == len(e) - 1:
            out.append(None)  # never back in this window
        else:
            out.append(float(data.t[window][outside[-1] + 1] - start))
    return out
