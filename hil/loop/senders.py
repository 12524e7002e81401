"""What the bench sends the board each step besides sensors and setpoints, as the other senders of a real system
would: the vehicle's battery (BATTERY_STATUS, as a battery component of the vehicle), the ground station's joystick
(MANUAL_CONTROL, as QGroundControl sends it), and the ground station's loss, which silences everything a ground
station sends. They go on the board's command link after the step's HIL frame, at their rates on the bench's
simulated clock; what was sent is recorded (`battery`, `manual_control` channels)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from firmware_interface.board import BoardSession
from firmware_interface.vehicle_codec import (
    BATTERY_COMPONENT_ID,
    ComponentSender,
    battery_status_fields,
    manual_control_fields,
)
from hil.scenario.schema import Scenario
from plant_fmu.state import StepOutputs

Sticks = tuple[float, float, float, float]  # pitch, roll, throttle, yaw in [-1, 1]
Window = tuple[float, float]  # start_s, end_s on the mission clock
CENTRED: Sticks = (0.0, 0.0, 0.0, 0.0)


def _within(windows: list[Window], mission_t: float) -> bool:
    """Asked a few times a step, of lists that are mostly empty: no generator made for an empty one (~0.1 µs each)."""
    return bool(windows) and any(start <= mission_t < end for start, end in windows)


@dataclass
class Periodic:
    """Due once per period of the bench's clock (integer µs), at the first step at or after each instant."""

    period_us: int
    next_us: int = 0

    def due(self, t_us: int) -> bool:
        if t_us < self.next_us:
            return False
        self.next_us += self.period_us * max(1, (t_us - self.next_us) // self.period_us + 1)
        return True


@dataclass
class Joystick:
    """The scenario's sticks at mission time t (centred before the mission clock runs: a ground station's joystick
    sends from the moment it connects), silent in its loss windows."""

    positions: Callable[[float], Sticks]
    schedule: Periodic
    loss: list[Window]

    def sticks(self, mission_t: float) -> Sticks:
        return self.positions(mission_t) if math.isfinite(mission_t) else CENTRED


@dataclass
class Senders:
    """The step's other senders: the battery's BATTERY_STATUS and the joystick's MANUAL_CONTROL at their rates, and
    the windows in which the ground station is lost (its joystick with it)."""

    battery: Periodic | None = None  # BATTERY_STATUS, when the scenario has a battery: section
    cells: int | None = None  # the pack's cells (our FMU gives 14 cell voltages, 0 beyond them); None: all given
    joystick: Joystick | None = None
    ground_station_loss: list[Window] = field(default_factory=list)
    _lost: dict[str, bool] = field(default_factory=lambda: {"ground station": False, "joystick": False})
    _battery_component: ComponentSender = field(default_factory=lambda: ComponentSender(BATTERY_COMPONENT_ID))

    def ground_station_lost(self, mission_t: float) -> bool:
        return _within(self.ground_station_loss, mission_t)

    def send(self, session: BoardSession, t_us: int, mission_t: float, truth: StepOutputs,
             notes: Callable[[str], None]) -> list[tuple[str, dict[str, Any]]]:
        """This step's messages on the command link; returns their channel payloads (SI, as sent)."""
        sent = self._battery_status(session, t_us, truth)
        gcs_lost = self.ground_station_lost(mission_t)
        self._note("ground station", gcs_lost, notes, "its heartbeats, commands, joystick and relayed traffic stop")
        if self.joystick is not None:
            stick_lost = gcs_lost or _within(self.joystick.loss, mission_t)
            self._note("joystick", stick_lost, notes, "no MANUAL_CONTROL")
            if self.joystick.schedule.due(t_us) and not stick_lost:
                sent += self._sticks(session, self.joystick.sticks(mission_t))
        return sent

    def _battery_status(self, session: BoardSession, t_us: int,
                        truth: StepOutputs) -> list[tuple[str, dict[str, Any]]]:
        if self.battery is None or not self.battery.due(t_us):  # the plant's battery read only when sent
            return []
        battery = truth.battery
        if battery is None:
            return []
        cells = battery.cell_voltages_v.tolist()[:self.cells]
        fields = battery_status_fields(battery.voltage_v, battery.current_a, battery.consumed_c, battery.remaining,
                                       cells)
        self._battery_component.send(session.link, "BATTERY_STATUS", fields)
        return [("battery", {"voltage_v": battery.voltage_v, "current_a": battery.current_a,
                             "consumed_c": battery.consumed_c, "remaining": battery.remaining,
                             "cell_voltages_v": cells})]

    @staticmethod
    def _sticks(session: BoardSession, sticks: Sticks) -> list[tuple[str, dict[str, Any]]]:
        info = session.report.info
        session.link.send_fields("MANUAL_CONTROL", manual_control_fields(info.system_id if info else 1, *sticks))
        return [("manual_control", dict(zip(("pitch", "roll", "throttle", "yaw"), sticks, strict=True)))]

    def _note(self, what: str, lost: bool, notes: Callable[[str], None], effect: str) -> None:
        if lost != self._lost[what]:
            self._lost[what] = lost
            notes(f"{what} lost: {effect}" if lost else f"{what} back")


def senders_for(scenario: Scenario, our_plant: bool) -> Senders:
    """The senders a scenario asks for (`battery:`, `manual_control:`, `faults.ground_station`); `our_plant`: the
    battery's cell count is the scenario's (another plant's battery is its own)."""
    battery = scenario.battery
    sticks = scenario.manual_control
    joystick = None if sticks is None else Joystick(sticks.positions(), Periodic(round(1e6 / sticks.rate_hz)),
                                                    [(w.start_s, w.end_s) for w in sticks.loss])
    cells = battery.cells if battery is not None and (our_plant or "cells" in battery.model_fields_set) else None
    return Senders(None if battery is None else Periodic(round(1e6 / battery.rate_hz)), cells, joystick,
                   [(w.start_s, w.end_s) for w in scenario.faults.ground_station])
