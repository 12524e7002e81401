"""What the world does to the vehicle at scenario time t: wind, disturbance force/torque, payload, motor health."""

from __future__ import annotations

import math
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


class Environment:
    """Evaluates the scenario's environment. Before the mission (t < 0: preflight, take-off) only the
    steady wind and the turbulence act; gusts, disturbances, payload steps and faults are mission events."""

    def __init__(self, scenario: Scenario, dt: float, rng: np.random.Generator, rotor_count: int) -> None:
        self.scenario = scenario
        self.healthy = (1.0,) * rotor_count
        self.steady = np.array(scenario.wind.steady_ned, float)
        self.gusts = [(g.start_s, g.duration_s, np.array(g.peak_ned, float)) for g in scenario.wind.gusts]
        turbulence = scenario.wind.turbulence
        self.turbulence = None
        if turbulence is not None:
            heading = math.atan2(self.steady[1], self.steady[0]) if np.any(self.steady[:2]) else 0.0
            self.turbulence = DrydenTurbulence(TURBULENCE_W20_KT[turbulence.intensity] * KNOT, turbulence.altitude_m,
                                               turbulence.airspeed_m_s, heading, dt, rng)
        self.force = scenario.disturbance.functions("force_ned")
        self.torque = scenario.disturbance.functions("torque_frd")
        self.payload = sorted((p.t_s, p.mass_kg) for p in scenario.payload)
        self.motor_faults = scenario.faults.motors
        failure = scenario.battery.failure if scenario.battery is not None else None
        self.cell_failure = None if failure is None else (failure.t_s, (failure.cell, failure.resistance_ohm,
                                                                         failure.voltage_v))

    def sample(self, t: float) -> EnvironmentSample:
        wind = self.steady.copy()
        if self.turbulence is not None:
            wind += self.turbulence.sample()
        if t < 0:
            return EnvironmentSample(wind, np.zeros(3), np.zeros(3), 0.0, self.healthy)
        for start, duration, peak in self.gusts:
            wind += one_minus_cosine(t, start, duration) * peak
        payload = 0.0
        for at, mass in self.payload:
            if t >= at:
                payload = mass
        health = list(self.healthy)
        for fault in self.motor_faults:
            if fault.start_s <= t < fault.end_s:
                health[fault.motor - 1] = min(health[fault.motor - 1], fault.health)
        failed = self.cell_failure[1] if self.cell_failure is not None and t >= self.cell_failure[0] else None
        return EnvironmentSample(wind, np.array([f(t) for f in self.force]), np.array([f(t) for f in self.torque]),
                                 payload, tuple(health), failed)
