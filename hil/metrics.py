"""Run metrics: the paper's tracking figures (Tables 1–2), the board's estimates, and timing."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from hil.frame import StepFrame
from hil.scenario.schema import Expect
from plant_fmu.plant import REAL_OUTPUT_NAMES

_OUT = {n: i for i, n in enumerate(REAL_OUTPUT_NAMES)}
_POS = [_OUT[n] for n in ("pos_n", "pos_e", "pos_d")]
_RPY = [_OUT[n] for n in ("roll", "pitch", "yaw")]


def _quat_to_rpy(q: list[float]) -> tuple[float, float, float]:
    w, x, y, z = q
    return (math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y)), math.asin(max(-1, min(1, 2 * (w * y - z * x)))),
            math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)))


def _wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2 * np.pi) - np.pi


def _stats(values: np.ndarray) -> dict[str, float]:
    if len(values) == 0:
        return {}
    return {"min": float(values.min()), "max": float(values.max()), "rms": float(np.sqrt(np.mean(values**2))),
            "max_abs": float(np.abs(values).max())}


def _percentiles(values: list[float]) -> dict[str, float]:
    if not values:
        return {}
    a = np.array(values)
    return {"p50": float(np.percentile(a, 50)), "p99": float(np.percentile(a, 99)), "max": float(a.max())}


@dataclass
class MetricsCollector:
    """Collects what the metrics need during the mission; `compute` turns it into figures."""

    settle_s: float
    t: list[float] = field(default_factory=list)
    pos: list[np.ndarray] = field(default_factory=list)
    ref: list[np.ndarray] = field(default_factory=list)
    attitude: list[tuple[float, np.ndarray, tuple[float, float, float]]] = field(default_factory=list)
    estimates: list[tuple[float, float, dict[str, float]]] = field(default_factory=list)  # t, true mass, values
    estimate_error: list[np.ndarray] = field(default_factory=list)  # board's LOCAL_POSITION_NED - truth, m
    attitude_estimate_error: list[np.ndarray] = field(default_factory=list)  # board's ATTITUDE - truth, rad
    step_wall_s: list[float] = field(default_factory=list)
    round_trip_s: list[float] = field(default_factory=list)
    step_starts: list[float] = field(default_factory=list)
    late_steps: int = 0
    breakdown_s: dict[str, float] = field(default_factory=lambda: dict.fromkeys(
        ("environment", "plant", "sensors", "encode_and_send", "sinks_of_previous_step", "wait_for_board", "frame"),
        0.0))
    sim_s: float = 0.0
    wall_s: float = 0.0

    def add(self, frame: StepFrame) -> None:
        self.step_wall_s.append(frame.step_wall_s)
        if frame.round_trip_s is not None:
            self.round_trip_s.append(frame.round_trip_s)
        if frame.phase != "mission" or frame.reference is None:
            return
        self.t.append(frame.mission_t)
        self.pos.append(frame.truth[_POS])
        self.ref.append(frame.reference.pos_ned)
        for kind, payload in frame.board:
            if kind == "ATTITUDE_TARGET":
                self.attitude.append((frame.mission_t, frame.truth[_RPY], _quat_to_rpy(payload["q"])))
            elif kind == "DEBUG_FLOAT_ARRAY":
                self.estimates.append((frame.mission_t, float(frame.truth[_OUT["total_mass"]]), payload["values"]))

    def add_estimate_error(self, error_ned: np.ndarray) -> None:
        """The board's own position estimate minus the truth (its frame offset at arming removed): a property
        of the flight stack under test, reported beside the tracking error."""
        self.estimate_error.append(error_ned)

    def add_attitude_estimate_error(self, error_rpy: np.ndarray) -> None:
        self.attitude_estimate_error.append(error_rpy)

    def compute(self, link_counters: dict[str, int], realtime: bool, period_s: float) -> dict[str, Any]:
        t = np.array(self.t)
        settled = t >= self.settle_s
        result: dict[str, Any] = {"settle_s": self.settle_s}
        if settled.any():
            err = (np.array(self.pos) - np.array(self.ref))[settled]
            result["position_error_m"] = {axis: _stats(err[:, i]) for i, axis in enumerate("xyz")}
        att = [(tt, truth, np.array(cmd)) for tt, truth, cmd in self.attitude if tt >= self.settle_s]
        if att:
            err = _wrap(np.array([a[1] - a[2] for a in att]))
            result["attitude_error_deg"] = {axis: _stats(np.degrees(err[:, i])) for i, axis in
                                            enumerate(("roll", "pitch", "yaw"))}
        if self.estimate_error:
            err = np.array(self.estimate_error)
            result["board_estimate_error_m"] = {axis: _stats(err[:, i]) for i, axis in enumerate("xyz")}
        if self.attitude_estimate_error:
            err = np.degrees(_wrap(np.array(self.attitude_estimate_error)))
            result["board_attitude_estimate_error_deg"] = {axis: _stats(err[:, i])
                                                           for i, axis in enumerate(("roll", "pitch", "yaw"))}
        if self.estimates:
            result["board_estimates"] = self._estimates()
        wall = self.wall_s
        result["timing"] = {
            "sim_s": self.sim_s, "wall_s": wall, "realtime_factor": self.sim_s / wall if wall > 0 else None,
            "step_wall_us": _percentiles([s * 1e6 for s in self.step_wall_s]),
            "round_trip_us": _percentiles([s * 1e6 for s in self.round_trip_s]),
            "breakdown_us_per_step": {k: v / max(len(self.step_wall_s), 1) * 1e6 for k, v in self.breakdown_s.items()},
        }
        if realtime and len(self.step_starts) > 1:
            periods = np.diff(self.step_starts)
            result["timing"]["period_jitter_us"] = _percentiles(list(np.abs(periods - period_s) * 1e6))
            result["timing"]["late_steps"] = self.late_steps
        result["link"] = link_counters
        return result

    def _estimates(self) -> dict[str, Any]:
        final = self.estimates[-1][2]
        out: dict[str, Any] = {"final": final}
        if "m_hat" in final:
            windows: list[dict[str, float]] = []
            for i, (tt, mass, values) in enumerate(self.estimates):
                last_of_window = i + 1 == len(self.estimates) or self.estimates[i + 1][1] != mass
                if last_of_window:
                    windows.append({"end_s": tt, "true_mass_kg": mass, "m_hat_kg": values["m_hat"],
                                    "error_pct": 100 * (values["m_hat"] - mass) / mass})
            out["mass_estimate_windows"] = windows
        return out


def check_expectations(expect: Expect | None, metrics: dict[str, Any]) -> list[str]:
    """The expectations not met, one line each (empty: all met)."""
    if expect is None:
        return []
    failures = []
    if expect.max_error_m is not None:
        limits = expect.max_error_m if isinstance(expect.max_error_m, tuple) else (expect.max_error_m,) * 3
        pos = metrics.get("position_error_m")
        if not pos:
            failures.append("no settled mission samples to check the position error")
        else:
            for axis, limit in zip("xyz", limits):
                found = pos[axis]["max_abs"]
                if found > limit:
                    failures.append(f"max |e_{axis}| = {found:.3f} m after {expect.settle_s:g} s, expected ≤ {limit:g} m")
    if expect.max_attitude_error_deg is not None:
        att = metrics.get("attitude_error_deg")
        if not att:
            failures.append("the board reported no commanded attitude (ATTITUDE_TARGET) to check against")
        else:
            worst = max(att["roll"]["max_abs"], att["pitch"]["max_abs"])
            if worst > expect.max_attitude_error_deg:
                failures.append(f"max roll/pitch error = {worst:.2f}°, expected ≤ {expect.max_attitude_error_deg:g}°")
    if expect.min_realtime_factor is not None:
        rtf = metrics["timing"]["realtime_factor"] or 0.0
        if rtf < expect.min_realtime_factor:
            failures.append(f"real-time factor = {rtf:.2f}, expected ≥ {expect.min_realtime_factor:g}")
    return failures
