"""What the world does to the vehicle at scenario time t: wind, disturbance force/torque, payload, motor health."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from hil.scenario.schema import Scenario
from hil.scenario.wind import (
    KNOT,
    TURBULENCE_W20_KT,
    DrydenTurbulence,
    one_minus_cosine,
)


@dataclass
class EnvironmentSample:
    wind_ned: np.ndarray
    force_ned: np.ndarray
    torque_frd: np.ndarray
    payload_kg: float
    motor_health: tuple[float, ...]  # per rotor, PX4's motor order
    battery_fault: tuple[int, float, float] | None = None  # a failed cell: (cell, Ω gained, V lost), from its time


NO_VECTOR = np.zeros(3)  # no force, no torque: one read-only array for every step that has none
NO_VECTOR.flags.writeable = False


class Environment:
    """Evaluates the scenario's environment. Before the mission (t < 0: preflight, take-off) only the
    steady wind and the turbulence act; gusts, disturbances, payload steps and faults are mission events."""

    def __init__(self, scenario: Scenario, dt: float, rng: np.random.Generator, rotor_count: int) -> None:
        self.scenario = scenario
        self.healthy = (1.0,) * rotor_count
        self.steady = np.array(scenario.wind.steady_ned, float)
        # sampled each step of the bench's, whose next step waits for it: plain floats until the arrays it returns
        self._steady = tuple(self.steady.tolist())
        self.gusts = [(g.start_s, g.duration_s, tuple(float(v) for v in g.peak_ned)) for g in scenario.wind.gusts]
        turbulence = scenario.wind.turbulence
        self.turbulence = None
        if turbulence is not None:
            heading = math.atan2(self.steady[1], self.steady[0]) if np.any(self.steady[:2]) else 0.0
            self.turbulence = DrydenTurbulence(TURBULENCE_W20_KT[turbulence.intensity] * KNOT, turbulence.altitude_m,
                                               turbulence.airspeed_m_s, heading, dt, rng)
        self.force = scenario.disturbance.functions("force_ned")
        self.torque = scenario.disturbance.functions("torque_frd")
        self._fixed_force = _fixed(scenario.disturbance.force_ned)
        self._fixed_torque = _fixed(scenario.disturbance.torque_frd)
        self.payload = sorted((p.t_s, p.mass_kg) for p in scenario.payload)
        self.motor_faults = scenario.faults.motors
        failure = scenario.battery.failure if scenario.battery is not None else None
        self.cell_failure = None if failure is None else (failure.t_s, (failure.cell, failure.resistance_ohm,
                                                                         failure.voltage_v))

    def sample(self, t: float) -> EnvironmentSample:
        north, east, down = self._steady
        if self.turbulence is not None:
            turbulence = self.turbulence.sample()
            north, east, down = north + turbulence[0], east + turbulence[1], down + turbulence[2]
        if t < 0:
            return EnvironmentSample(np.array((north, east, down)), NO_VECTOR, NO_VECTOR, 0.0, self.healthy)
        for start, duration, peak in self.gusts:
            shape = one_minus_cosine(t, start, duration)
            north, east, down = north + shape * peak[0], east + shape * peak[1], down + shape * peak[2]
        payload = 0.0
        for at, mass in self.payload:
            if t >= at:
                payload = mass
        health = self.healthy
        if self.motor_faults:
            scaled = list(health)
            for fault in self.motor_faults:
                if fault.start_s <= t < fault.end_s:
                    scaled[fault.motor - 1] = min(scaled[fault.motor - 1], fault.health)
            health = tuple(scaled)
        failed = self.cell_failure[1] if self.cell_failure is not None and t >= self.cell_failure[0] else None
        force = self._fixed_force if self._fixed_force is not None else np.array([f(t) for f in self.force])
        torque = self._fixed_torque if self._fixed_torque is not None else np.array([f(t) for f in self.torque])
        return EnvironmentSample(np.array((north, east, down)), force, torque, payload, health, failed)


def _fixed(components: Sequence[float | str]) -> np.ndarray | None:
    """A disturbance of numbers only, as the one read-only array every step shares; None for expressions of t."""
    if any(isinstance(c, str) for c in components):
        return None
    vector = np.array(components, float)
    vector.flags.writeable = False
    return vector
