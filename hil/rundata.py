"""A run's recording as arrays, for reports and comparisons (mission phase only, mission time in s)."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import orjson
import yaml
from mcap.reader import make_reader


def _rpy(q: list[float]) -> tuple[float, float, float]:
    w, x, y, z = q
    return (math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y)), math.asin(max(-1, min(1, 2 * (w * y - z * x)))),
            math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)))


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


def load_run(run_dir: Path) -> RunData:
    states: dict[int, dict] = {}
    refs: dict[int, list[float]] = {}
    envs: dict[int, dict] = {}
    cmd: list[tuple[int, tuple[float, float, float]]] = []
    est: list[tuple[int, dict[str, float]]] = []
    with open(run_dir / "recording.mcap", "rb") as f:
        topics = ["hil/state", "hil/reference", "hil/environment", "hil/board"]
        for _, channel, message in make_reader(f).iter_messages(topics=topics):
            sample = orjson.loads(message.data)
            t_us = sample["t_us"]
            if channel.topic == "hil/state":
                if sample["phase"] == "mission":
                    states[t_us] = sample
            elif channel.topic == "hil/reference":
                refs[t_us] = sample["pos_ned"]
            elif channel.topic == "hil/environment":
                envs[t_us] = sample
            elif sample.get("message") == "ATTITUDE_TARGET":
                cmd.append((t_us, _rpy(sample["q"])))
            elif sample.get("message") == "DEBUG_FLOAT_ARRAY":
                est.append((t_us, sample["values"]))
    steps = sorted(states)
    mission_t = {t: states[t]["mission_t"] for t in steps}
    first, last = (steps[0], steps[-1]) if steps else (0, -1)
    scenario = yaml.safe_load((run_dir / "scenario.yaml").read_text())
    keys = sorted({k for _, values in est for k in values})
    in_mission = [(t, v) for t, v in est if first <= t <= last]

    def at(t_us: int) -> float:  # mission time of a bench time inside the mission
        return mission_t.get(t_us, (t_us - first) * 1e-6 + (mission_t[first] if steps else 0.0))

    return RunData(
        name=scenario["name"], controller=scenario["board"]["controller"],
        t=np.array([mission_t[t] for t in steps]),
        pos=np.array([states[t]["pos_ned"] for t in steps]).reshape(-1, 3),
        ref=np.array([refs[t] for t in steps]).reshape(-1, 3),
        rpy=np.array([states[t]["rpy"] for t in steps]).reshape(-1, 3),
        mass=np.array([states[t]["total_mass"] for t in steps]),
        force=np.array([envs[t]["force_ned"] for t in steps]).reshape(-1, 3),
        cmd_t=np.array([at(t) for t, _ in cmd if first <= t <= last]),
        cmd_rpy=np.array([r for t, r in cmd if first <= t <= last]).reshape(-1, 3),
        est_t=np.array([at(t) for t, _ in in_mission]),
        estimates={k: np.array([v.get(k, np.nan) for _, v in in_mission]) for k in keys},
        metrics=json.loads((run_dir / "metrics.json").read_text()),
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
    for start, end in zip(bounds, bounds[1:]):
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
