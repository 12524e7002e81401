"""What a scenario says of failsafes: the vehicle's battery (`battery:`), the sticks a ground station's joystick
sends (`manual_control:`), the ground station's loss (`faults.ground_station`), the failsafe the flight must show
(`expect.failsafe`), and the PX4 parameters that configure the board's reactions (`board.params`).

Times are on the mission clock, as every other scenario time. Stick positions are PX4's manual_control_setpoint:
each in [-1, 1], pitch forward, roll right, yaw clockwise, throttle up, 0 centred (throttle 0 holds the altitude in
POSCTL; MANUAL_CONTROL carries it as z = 500).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from pydantic import Field, model_validator

from firmware_interface.emulator.px4_params import PX4_PARAMS
from hil.scenario.expressions import EvaluationError, ExpressionError, compile_expression
from hil.scenario.fields import Duration, ExpressionOrNumber, Length, MissionTime, ScenarioModel, UntilEnd
from plant_fmu.variables import MAX_CELLS, PARAMETER_DEFAULTS

if TYPE_CHECKING:
    from hil.scenario.schema import Scenario

STICKS = ("pitch", "roll", "throttle", "yaw")
STICK_SAMPLES = 2001  # a stick expression is checked at this many evenly spaced times over the mission ...
STICK_SAMPLE_S = 0.1  # ... or every 0.1 s when the mission is shorter
Trigger = Literal["battery low", "manual control lost", "data link lost", "gps lost"]
Action = Literal["rtl", "land", "hold", "none"]
Loc = tuple[str | int, ...]
# the FMU parameter of each field of `battery:` (docs/plant.md)
BATTERY_PARAMETERS = {"cells": "battery_cells", "capacity_ah": "battery_capacity",
                      "initial_charge": "battery_initial_soc", "cell_resistance_ohm": "battery_cell_resistance",
                      "efficiency": "battery_efficiency", "base_current_a": "battery_base_current"}


class CellFailure(ScenarioModel):
    """One cell fails at a mission time: it gains series resistance and loses open-circuit voltage."""

    cell: int = Field(ge=1, le=MAX_CELLS, description="the failing cell, 1 to battery.cells")
    t_s: MissionTime
    resistance_ohm: float = Field(0.0, ge=0, le=10.0, description="series resistance the cell gains, Ω")
    voltage_v: float = Field(0.0, ge=0, le=4.2, description="open-circuit voltage the cell loses, V")

    @model_validator(mode="after")
    def _fails(self) -> CellFailure:
        if self.resistance_ohm == 0 and self.voltage_v == 0:
            raise ValueError("a cell failure needs resistance_ohm > 0 or voltage_v > 0")
        return self


def _default(name: str) -> float:
    return float(PARAMETER_DEFAULTS[name])


class Battery(ScenarioModel):
    """The plant's battery pack (its FMU parameters) and the BATTERY_STATUS the bench sends the board for it."""

    cells: int = Field(int(_default("battery_cells")), ge=1, le=MAX_CELLS, description="LiPo cells in series")
    capacity_ah: float = Field(_default("battery_capacity"), gt=0, le=1000.0, description="charge of the full pack")
    initial_charge: float = Field(_default("battery_initial_soc"), ge=0, le=1, description="state of charge at start")
    cell_resistance_ohm: float = Field(_default("battery_cell_resistance"), ge=0, le=10.0)
    efficiency: float = Field(_default("battery_efficiency"), gt=0, le=1, description="rotor shaft over electrical")
    base_current_a: float = Field(_default("battery_base_current"), ge=0, le=1000.0, description="avionics, payload")
    rate_hz: float = Field(2.0, ge=1, le=10, description="BATTERY_STATUS per second of simulated time")
    failure: CellFailure | None = None

    def fmu_parameters(self, every: bool) -> dict[str, float]:
        """The pack as FMU parameters: every field (our FMU), or those the file gives (a foreign FMU, whose own
        defaults are its battery)."""
        given = self.model_fields_set
        return {parameter: float(getattr(self, name)) for name, parameter in BATTERY_PARAMETERS.items()
                if every or name in given}


class StickPoint(ScenarioModel):
    """A row of a stick table: the positions at a mission time (straight lines between rows)."""

    t_s: MissionTime
    pitch: float = Field(0.0, ge=-1, le=1)
    roll: float = Field(0.0, ge=-1, le=1)
    throttle: float = Field(0.0, ge=-1, le=1)
    yaw: float = Field(0.0, ge=-1, le=1)


class StickLoss(ScenarioModel):
    """Mission times in which no MANUAL_CONTROL is sent (the joystick's link is lost)."""

    start_s: MissionTime
    end_s: UntilEnd = math.inf


class ManualControl(ScenarioModel):
    """Sticks as QGroundControl's joystick sends them: expressions of t, or a table (`points`)."""

    pitch: ExpressionOrNumber = 0.0
    roll: ExpressionOrNumber = 0.0
    throttle: ExpressionOrNumber = 0.0
    yaw: ExpressionOrNumber = 0.0
    points: list[StickPoint] = Field(default_factory=list, max_length=10_000)
    rate_hz: float = Field(25.0, ge=5, le=50, description="MANUAL_CONTROL per second (QGroundControl: 25)")
    loss: list[StickLoss] = Field(default_factory=list, max_length=100)

    def positions(self) -> Callable[[float], tuple[float, float, float, float]]:
        """(pitch, roll, throttle, yaw) at mission time t; an expression outside [-1, 1] raises EvaluationError."""
        if self.points:
            times = np.array([p.t_s for p in self.points])
            columns = [np.array([getattr(p, stick) for p in self.points]) for stick in STICKS]
            return lambda t: tuple(float(np.interp(t, times, column)) for column in columns)  # type: ignore[return-value]
        functions = [_bounded(compile_expression(getattr(self, stick), f"manual_control.{stick}"), getattr(self, stick),
                              f"manual_control.{stick}") for stick in STICKS]
        return lambda t: tuple(f(t) for f in functions)  # type: ignore[return-value]

    def sending(self, t: float) -> bool:
        """Whether the joystick's MANUAL_CONTROL goes out at mission time t (outside every loss window)."""
        return not any(window.start_s <= t < window.end_s for window in self.loss)


def _bounded(function: Callable[[float], float], text: str | float, field: str) -> Callable[[float], float]:
    def stick(t: float) -> float:
        value = function(t)
        if not -1.0 <= value <= 1.0:
            raise EvaluationError(str(text), field, t, f"{value:.3g} is outside the stick's range [-1, 1]")
        return value

    return stick


class GroundStationLoss(ScenarioModel):
    """Mission times in which nothing a ground station sends reaches the board (its heartbeats, commands and
    joystick, the bench's and the relayed ones) and the board's traffic reaches no ground station; the HIL frames,
    the battery's messages and the bench's setpoints keep flowing."""

    start_s: MissionTime
    end_s: UntilEnd = math.inf


class FailsafeExpected(ScenarioModel):
    """What the board must do after a failsafe's trigger."""

    after: Trigger
    action: Action
    within_s: Duration = Field(description="from the trigger to the board flying the action's mode")
    landed_within_m_of_home: Length | None = Field(None, description="then landed and disarmed this close to home")


def px4_parameter_problems(params: dict[str, float]) -> Iterator[tuple[Loc, Any, str]]:
    """`board.params`: PX4's names that both the emulator and PX4 read, within PX4's bounds, integers where PX4's
    parameter is an INT32."""
    for name, value in params.items():
        known = PX4_PARAMS.get(name)
        if known is None:
            yield ("board", "params", name), value, (f"unknown parameter {name!r:.40}; expected one the emulator "
                                                     f"and PX4 both read: {', '.join(PX4_PARAMS)}")
        elif not known.low <= value <= known.high:
            yield ("board", "params", name), value, f"{value:g} is outside PX4's bounds [{known.low:g}, {known.high:g}]"
        elif known.integer and value != round(value):
            yield ("board", "params", name), value, f"{value:g}: PX4's {name} is an integer"


def px4_parameter_values(params: dict[str, float]) -> dict[str, float | int]:
    """`board.params` as they go on the wire: PX4's INT32 parameters as ints."""
    return {name: int(value) if PX4_PARAMS[name].integer else float(value) for name, value in params.items()}


def parameter(scenario: Scenario, name: str) -> float:
    """A PX4 parameter as the scenario sets it on the board, or PX4's default."""
    return float(scenario.board.params.get(name, PX4_PARAMS[name].default))


def failsafe_problems(scenario: Scenario) -> Iterator[tuple[Loc, Any, str]]:
    """The failsafe parts of a scenario checked against each other and the mission."""
    yield from px4_parameter_problems(scenario.board.params)
    own = scenario.board.config.get("params", {})
    for name in sorted(set(own) & set(scenario.board.params)):
        if own[name] != scenario.board.params[name]:
            yield ("board", "params", name), scenario.board.params[name], (
                f"board.config.params sets it to {own[name]}; expected one value")
    sticks = scenario.manual_control
    if sticks is not None:
        yield from _stick_problems(sticks, scenario.duration_s)
    if scenario.pilot.type == "sticks" and sticks is None:
        yield ("pilot",), "sticks", ("a pilot with sticks needs the sticks: manual_control: {throttle: ..., ...}; "
                                     "expected a manual_control section")
    battery = scenario.battery
    if battery is not None and battery.failure is not None and battery.failure.cell > battery.cells:
        yield ("battery", "failure", "cell"), battery.failure.cell, (
            f"cell {battery.failure.cell}: the pack has {battery.cells} cells; expected 1 to {battery.cells}")
    if battery is not None:
        for name, parameter_name in BATTERY_PARAMETERS.items():
            if parameter_name in scenario.vehicle.overrides and name in battery.model_fields_set:
                yield ("vehicle", parameter_name), scenario.vehicle.overrides[parameter_name], (
                    f"battery.{name} sets it too; expected one of the two")
    for loc, expected in (("expect",), scenario.expect), (("expect", "px4"), getattr(scenario.expect, "px4", None)):
        failsafe = getattr(expected, "failsafe", None)
        if failsafe is not None and (missing := _missing_trigger(scenario, failsafe.after)) is not None:
            yield (*loc, "failsafe", "after"), failsafe.after, missing


def _stick_problems(sticks: ManualControl, duration_s: float) -> Iterator[tuple[Loc, Any, str]]:
    given = [stick for stick in STICKS if getattr(sticks, stick) != 0]
    if sticks.points and given:
        yield ("manual_control", given[0]), getattr(sticks, given[0]), (
            "the sticks are given twice, as expressions and as points; expected one of the two")
        return
    times = [p.t_s for p in sticks.points]
    if any(later <= earlier for earlier, later in itertools.pairwise(times)):
        yield ("manual_control", "points"), times, "the points' t_s must increase; expected rows in time order"
    count = min(STICK_SAMPLES, int(duration_s / STICK_SAMPLE_S) + 1)
    samples = np.linspace(0.0, duration_s, max(count, 2)).tolist()
    for stick in given:
        try:
            function = _bounded(compile_expression(getattr(sticks, stick)), getattr(sticks, stick), "")
            for t in samples:
                function(t)
        except ExpressionError as exc:
            yield ("manual_control", stick), getattr(sticks, stick), f"{exc}; expected a stick position from -1 to 1"


def _missing_trigger(scenario: Scenario, after: str) -> str | None:
    """Why the scenario cannot show the trigger an expected failsafe follows (None: it can)."""
    if after == "battery low" and scenario.battery is None:
        return "'battery low' needs a battery: section (the bench sends its BATTERY_STATUS); expected one"
    if after == "manual control lost" and not joystick_losses(scenario):
        return ("'manual control lost' needs manual_control: with a loss: window (or a ground-station loss, which "
                "takes the joystick with it); expected one")
    if after == "data link lost" and not scenario.faults.ground_station:
        return "'data link lost' needs faults.ground_station: [{start_s: ...}]; expected one"
    if after == "gps lost" and not gps_dropouts(scenario):
        return ("'gps lost' needs a GPS dropout: faults.sensors: [{sensor: gps, kind: dropout, start_s: ...}]; "
                "expected one")
    return None


def joystick_losses(scenario: Scenario) -> list[tuple[float, float]]:
    """When the scenario's sticks stop, (start_s, end_s) on the mission clock: their own loss windows and the
    ground station's (QGroundControl's joystick goes with it)."""
    if scenario.manual_control is None:
        return []
    return sorted([(w.start_s, w.end_s) for w in scenario.manual_control.loss]
                  + [(w.start_s, w.end_s) for w in scenario.faults.ground_station])


def gps_dropouts(scenario: Scenario) -> list[tuple[float, float]]:
    """The GPS dropouts of the scenario, (start_s, end_s) on the mission clock."""
    return sorted((f.start_s, f.end_s) for f in (*scenario.sensors.faults, *scenario.faults.sensors)
                  if f.sensor == "gps" and f.kind == "dropout")
