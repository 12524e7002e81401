"""Run metrics: the paper's tracking figures (Tables 1–2) and the board's estimates, from each step's frame."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from firmware_interface.emulator.geometry import quat_to_euler
from hil.loop.frame import StepFrame
from hil.loop.sink import Outcome
from hil.loop.streaming_stats import Extremes
from hil.scenario.schema import Expect


def _wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2 * np.pi) - np.pi


def _window_figures(t: float, mass: float, values: dict[str, float]) -> dict[str, float]:
    """m̂ at the end of a payload window against the true mass there."""
    return {"end_s": t, "true_mass_kg": mass, "m_hat_kg": values["m_hat"],
            "error_pct": 100 * (values["m_hat"] - mass) / mass}


XYZ = ("x", "y", "z")
RPY = ("roll", "pitch", "yaw")


@dataclass
class MetricsCollector:
    """Accumulates what the metrics need during the run in constant memory (streaming statistics: an
    hours-long run costs what a minute costs); `compute` turns it into figures."""

    settle_s: float
    position_error: Extremes = field(default_factory=lambda: Extremes(3))  # truth - reference, m, once settled
    attitude_error: Extremes = field(default_factory=lambda: Extremes(3))  # truth - commanded, rad, once settled
    estimate_error: Extremes = field(default_factory=lambda: Extremes(3))  # board's LOCAL_POSITION_NED - truth, m
    attitude_estimate_error: Extremes = field(default_factory=lambda: Extremes(3))  # board's ATTITUDE - truth
    mission_steps: int = 0
    _final_estimates: dict[str, float] | None = None
    _windows: list[dict[str, float]] = field(default_factory=list)  # m̂ at the end of each payload window
    _window: tuple[float, float, dict[str, float]] | None = None  # the current window's latest (t, mass, values)

    def on_step(self, frame: StepFrame) -> None:
        """A sink of the loop: each step's frame, in order."""
        self.add(frame)

    def on_event(self, t_us: int, text: str) -> None:
        """Events carry nothing the tracking figures need."""

    def close(self, outcome: Outcome) -> None:
        """Nothing to close: `compute` gives the figures."""

    def add(self, frame: StepFrame) -> None:
        if frame.phase != "mission":
            return
        self.mission_steps += 1
        settled = frame.mission_t >= self.settle_s
        if settled and frame.reference is not None:  # a board flying its own mission has none
            self.position_error.add(frame.truth.pos_ned - frame.reference.pos_ned)
        for kind, payload in frame.board:
            if kind == "ATTITUDE_TARGET" and settled:
                self.attitude_error.add(_wrap(frame.truth.rpy - quat_to_euler(payload["q"])))
            elif kind == "DEBUG_FLOAT_ARRAY":
                self._add_estimates(frame.mission_t, frame.truth.total_mass_kg, payload["values"])
            elif kind == "LOCAL_POSITION_NED" and frame.board_offset_ned is not None:
                # the board's own estimate minus the truth (its frame offset at arming removed): a property of
                # the flight stack under test, reported beside the tracking error
                self.estimate_error.add(np.array(payload["pos_ned"]) - frame.board_offset_ned - frame.truth.pos_ned)
            elif kind == "ATTITUDE":
                self.attitude_estimate_error.add(_wrap(np.array(payload["rpy"]) - frame.truth.rpy))

    def _add_estimates(self, t: float, mass: float, values: dict[str, float]) -> None:
        self._final_estimates = values
        if self._window is not None and self._window[1] != mass:
            self._close_window()
        self._window = (t, mass, values)

    def _close_window(self) -> None:
        if self._window is not None and "m_hat" in self._window[2]:
            self._windows.append(_window_figures(*self._window))

    def compute(self) -> dict[str, Any]:
        result: dict[str, Any] = {"settle_s": self.settle_s}
        figures = {"position_error_m": self.position_error.stats(XYZ),
                   "attitude_error_deg": self.attitude_error.stats(RPY, math.degrees(1.0)),
                   "board_estimate_error_m": self.estimate_error.stats(XYZ),
                   "board_attitude_estimate_error_deg": self.attitude_estimate_error.stats(RPY, math.degrees(1.0))}
        result.update({name: value for name, value in figures.items() if value})
        if self._final_estimates is not None:
            result["board_estimates"] = self._estimates()
        return result

    def _estimates(self) -> dict[str, Any]:
        out: dict[str, Any] = {"final": self._final_estimates}
        windows = self._windows + ([_window_figures(*self._window)]
                                   if self._window is not None and "m_hat" in self._window[2] else [])
        if windows:
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
            for axis, limit in zip("xyz", limits, strict=True):
                found = pos[axis]["max_abs"]
                if found > limit:
                    failures.append(f"max |e_{axis}| = {found:.3f} m after {expect.settle_s:g} s, "
                                    f"expected ≤ {limit:g} m")
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


def slip_note(timing: dict[str, Any]) -> str:
    """", slipped N x (T ms in all)" for a paced run whose schedule slipped after stalls, and how often and how long
    the simulation waited for a board process this machine starved of CPU (`board_starvation`); else ""."""
    slips, waits = timing.get("slips") or {}, timing.get("board_cpu_waits") or {}
    note = f", slipped {slips['count']}x ({slips['total_s'] * 1e3:.0f} ms in all)" if slips.get("count") else ""
    if waits.get("count"):
        note += (f"; waited {waits['count']}x for the board's process to get a CPU "
                 f"({waits['total_s'] * 1e3:.0f} ms in all)")
    return note
