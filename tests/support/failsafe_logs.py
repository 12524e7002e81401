"""What a failsafe flight left behind, read with independent readers: the recording (mcap), the link's tlog
(pymavlink), PX4's flight log (pyulog). Times on the bench's clock: a frame in the tlog takes the bench time of the
last HIL_SENSOR the bench sent before it (the bench writes each step's frames after that step's HIL_SENSOR)."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from mcap.reader import make_reader
from pymavlink import mavutil
from pyulog import ULog

BENCH_COMPONENT = 51  # firmware_interface.board.BENCH_COMPONENT_ID
NAV_POSCTL, NAV_LOITER, NAV_RTL, NAV_DESCEND, NAV_LAND = 2, 4, 5, 12, 18  # PX4's vehicle_status.nav_state


def recorded(run_dir: Path, topic: str) -> list[dict[str, Any]]:
    with open(run_dir / "recording.mcap", "rb") as f:
        return [json.loads(m.data) for _, _, m in make_reader(f).iter_messages(topics=[f"hil/{topic}"])]


def mission_start_us(run_dir: Path) -> int:
    """The bench time at which the mission clock started (mission time 0)."""
    return next(s["t_us"] for s in recorded(run_dir, "state") if s["mission_t"] is not None and s["mission_t"] >= 0)


def event_us(run_dir: Path, text: str, after_us: int = -1) -> int:
    """The bench time of the first run event that starts with `text` (after `after_us`)."""
    return next(e["t_us"] for e in recorded(run_dir, "events") if e["text"].startswith(text) and e["t_us"] > after_us)


def mode_us(run_dir: Path, custom_mode: int, after_us: int = -1) -> int:
    """The bench time of the first HEARTBEAT of the board in `custom_mode` (after `after_us`)."""
    return next(h["t_us"] for h in recorded(run_dir, "board/heartbeat")
                if h["custom_mode"] == custom_mode and h["t_us"] > after_us)


@dataclass(frozen=True)
class Frame:
    t_us: int  # the bench's clock
    message: Any  # pymavlink's message

    @property
    def kind(self) -> str:
        return str(self.message.get_type())

    @property
    def from_bench(self) -> bool:
        return int(self.message.get_srcComponent()) in (BENCH_COMPONENT, 180)


def tlog_frames(run_dir: Path) -> list[Frame]:
    """Every frame of link.tlog with its bench time."""
    log = mavutil.mavlink_connection(str(run_dir / "link.tlog"), dialect="common")
    frames, t_us = [], 0
    while (message := log.recv_match()) is not None:
        if message.get_type() == "HIL_SENSOR":
            t_us = int(message.time_usec)
        frames.append(Frame(t_us, message))
    return frames


def last_sent_us(frames: list[Frame], kind: str, before_us: int | None = None) -> int:
    """The bench time of the last message of `kind` the bench sent (before `before_us`)."""
    return max(f.t_us for f in frames if f.kind == kind and f.from_bench
               and (kind != "HEARTBEAT" or f.message.type == mavutil.mavlink.MAV_TYPE_GCS)
               and (before_us is None or f.t_us < before_us))


class Px4Log:
    """PX4's ULog of the run on PX4's own clock, with the bench's times put on that clock (`px4_us`). In SITL's
    lockstep PX4's clock is the bench's: PX4 sets it from each HIL_SENSOR's time_usec. On PX4's HITL path (a build
    without lockstep) PX4's clock is the machine's CLOCK_MONOTONIC (drv_hrt.cpp, hrt_absolute_time), which the
    bench records at the start of each step (hil/timing's start_monotonic_us). So a bench time is put on PX4's
    clock through the step that carried it, slips and all: two clocks matched once, at the arming, drift apart by
    each slip of a paced bench after a stall of the machine (0.26 s in a CI run on a stalling host)."""

    def __init__(self, run_dir: Path, topics: list[str]) -> None:
        (path,) = sorted((run_dir / "px4" / "log").rglob("*.ulg"))
        self.ulog = ULog(str(path), ["vehicle_status", *topics])
        self.lockstep = json.loads((run_dir / "meta.json").read_text())["pacing"] == "lockstep"
        steps = [] if self.lockstep else recorded(run_dir, "timing")
        self._step_us = np.array([s["t_us"] for s in steps], dtype=np.int64)
        self._step_start_monotonic_us = np.array([s["start_monotonic_us"] for s in steps], dtype=np.int64)

    def px4_us(self, bench_us: int) -> int:
        """A bench time on PX4's clock: itself in lockstep, else the start of the bench's step of that time."""
        if self.lockstep:
            return bench_us
        step = int(np.searchsorted(self._step_us, bench_us))
        assert self._step_us[step] == bench_us, f"no bench step at {bench_us} us"
        return int(self._step_start_monotonic_us[step])

    def data(self, topic: str, instance: int = 0) -> dict[str, np.ndarray]:
        return self.ulog.get_dataset(topic, instance).data

    def times(self, topic: str) -> np.ndarray:
        return self.data(topic)["timestamp"].astype(np.int64)

    def changes(self, topic: str, key: str) -> list[tuple[int, float]]:
        """(PX4's time, new value) at each change of `key`."""
        values, t_us = self.data(topic)[key], self.times(topic)
        return [(int(t_us[i + 1]), float(values[i + 1])) for i in np.nonzero(np.diff(values.astype(float)))[0]]

    def first(self, topic: str, key: str, value: float, after_us: int = 0) -> int:
        """PX4's time at which `key` first became `value` after `after_us` (PX4's clock)."""
        return next(t for t, v in self.changes(topic, key) if v == value and t > after_us)

    def instances(self, topic: str) -> list[int]:
        return sorted(d.multi_id for d in self.ulog.data_list if d.name == topic)

    def parameter(self, name: str) -> float:
        return float(self.ulog.initial_parameters[name])
