"""The scenario file, as a typed schema. Every field has a default except the name.

Numbers: every float in a scenario is finite (`allow_inf_nan=False` on the base model, and on the sensor and
emulator models a scenario reaches), except a fault's `end_s`, where `.inf` means "until the end". Bounds that
keep a run possible and finite are on the fields' types (`hil.scenario.fields`); the `reference:` types are in
`hil.scenario.reference`. What depends on several fields is checked once the whole file has parsed
(`Scenario._consistent`): every time on the mission clock inside the mission, intervals that end after they
start, expressions over the mission, what the reference can fly within the mission, and the scenario against
its plant (`hil.scenario.plant`: the mapping file and the FMU's model description are read, cached).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal, TypeAlias

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    Tag,
    ValidationError,
    ValidationInfo,
    create_model,
    field_validator,
    model_validator,
)
from pydantic_core import InitErrorDetails, PydanticCustomError

from firmware_interface.airframes import AirframeName
from firmware_interface.emulator.config import MAX_ROTORS, build_config
from firmware_interface.emulator.control.registry import ControllerName
from firmware_interface.px4_modes import PX4_MODE_NAMES
from hil.channels import CHANNEL_MODELS
from hil.scenario.expressions import ExpressionError, compile_expression
from hil.scenario.failsafe import Battery, FailsafeExpected, GroundStationLoss, ManualControl, failsafe_problems
from hil.scenario.fields import (
    MAX_MASS_KG,
    SCENARIO_DIR,
    Duration,
    ExpressionOrNumber,
    Length,
    Mass,
    MissionTime,
    PositiveFloat,
    ScenarioModel,
    Speed,
    UntilEnd,
    WindVector,
    number_unless,
)
from hil.scenario.pilot_checks import pilot_problems, resolve_end
from hil.scenario.pilot_spec import BenchPilotSpec, End, PilotSpec
from hil.scenario.plant import plant_problems
from hil.scenario.reference import HoverRef, Reference
from hil.sensors.faults import SensorFault
from hil.sensors.geodesy import Home
from hil.sensors.suite import SensorsConfig
from plant_fmu.variables import PARAMETER_NAMES

MAX_RATE_HZ = 10_000.0  # telemetry rates
MIN_INTEGRATION_STEP_S = 1e-6
CHECK_ERROR = "scenario_check"  # the error type of the checks across fields (their messages say it all)
MISSION_TIMES = ("start_s", "t_s", "settle_s")  # fields, in any part of a scenario, timed on the mission clock
READ_PLANT = "read_plant"  # validation context: False to take the plant field as written (a recorded run)


ErrorBound: TypeAlias = Annotated[
    Annotated[PositiveFloat, Tag("number")]
    | Annotated[tuple[PositiveFloat, PositiveFloat, PositiveFloat], Tag("other")], number_unless((list, tuple))]
if TYPE_CHECKING:  # the names are data (the channel table, PX4's modes); to a type checker they are strings
    ChannelName = str
    PX4ModeName = str
else:
    ChannelName = Literal[tuple(CHANNEL_MODELS)]
    PX4ModeName = Literal[PX4_MODE_NAMES]


_BOUNDS: dict[str, dict[str, float]] = {  # FMU parameters beyond finite; any other parameter is any number
    "mass": {"gt": 0, "le": MAX_MASS_KG},
    "integration_step": {"ge": MIN_INTEGRATION_STEP_S},
    **{name: {"gt": 0} for name in ("Ixx", "Iyy", "Izz", "arm_length", "thrust_max", "rotor_speed_max")},
    **{name: {"ge": 0, "le": 1} for name in ("thrust_curve_k", "rotor_reversible")},
    **{name: {"ge": 0} for name in ("motor_tau", "yaw_moment_coeff", "drag_coeff_x", "drag_coeff_y",
                                    "drag_coeff_z", "rotor_drag_coeff", "induced_inflow_coeff",
                                    "translational_lift_coeff", "flapping_coeff", "parasitic_drag_area_x",
                                    "parasitic_drag_area_y", "parasitic_drag_area_z", "air_density", "g")},
}

if TYPE_CHECKING:  # the fields are data (the FMU's parameter table); to a type checker any name is a parameter
    class _VehicleParameters(BaseModel):
        def __getattr__(self, name: str) -> float | None: ...
else:
    _VehicleParameters = create_model(  # one optional field per FMU parameter, so a typo names its own key
        "_VehicleParameters",
        __base__=ScenarioModel,
        **{name: (float | None, Field(None, **_BOUNDS.get(name, {}))) for name in PARAMETER_NAMES},
    )


class Vehicle(_VehicleParameters):
    """An airframe preset plus overrides of the plant FMU's parameters: our FMU's (mass, Ixx, thrust_max, ...,
    bounded here), or any other name a foreign FMU has (a finite number; `Scenario` checks it against the FMU)."""

    model_config = ConfigDict(extra="allow")
    __pydantic_extra__: dict[str, float] = Field(init=False)

    preset: AirframeName = "inspection_quad"

    @property
    def overrides(self) -> dict[str, float]:
        ours = {name: value for name in PARAMETER_NAMES if (value := getattr(self, name)) is not None}
        return {**ours, **(self.model_extra or {})}


class Gust(ScenarioModel):
    start_s: MissionTime
    duration_s: Duration
    peak_ned: WindVector


class Turbulence(ScenarioModel):
    intensity: Literal["light", "moderate", "severe"] = "light"
    altitude_m: Length = 10.0
    airspeed_m_s: Speed = 5.0


class Wind(ScenarioModel):
    steady_ned: WindVector = (0.0, 0.0, 0.0)
    gusts: list[Gust] = Field(default_factory=list)
    turbulence: Turbulence | None = None


class Disturbance(ScenarioModel):
    """Expressions of t (s): force in NED (N), torque in FRD (N·m)."""

    force_ned: tuple[ExpressionOrNumber, ExpressionOrNumber, ExpressionOrNumber] = (0.0, 0.0, 0.0)
    torque_frd: tuple[ExpressionOrNumber, ExpressionOrNumber, ExpressionOrNumber] = (0.0, 0.0, 0.0)

    @field_validator("force_ned", "torque_frd")
    @classmethod
    def _compiles(cls, value: tuple[str | float, ...]) -> tuple[str | float, ...]:
        """Refused as the file loads: syntax, names, length and depth, failure at t = 0."""
        for item in value:
            compile_expression(item)
        return value

    def functions(self, name: Literal["force_ned", "torque_frd"]) -> list[Callable[[float], float]]:
        """The three components of `name` as functions of t whose errors name their field."""
        return [compile_expression(item, f"disturbance.{name}.{axis}") for axis, item in enumerate(getattr(self, name))]


class PayloadStep(ScenarioModel):
    t_s: MissionTime
    mass_kg: Mass


class MotorFault(ScenarioModel):
    motor: int = Field(ge=1, le=MAX_ROTORS, description="PX4's motor number, 1 to the plant's rotor count")
    start_s: MissionTime
    end_s: UntilEnd = math.inf
    health: float = Field(ge=0, le=1, description="thrust multiplier while the fault lasts")


class LinkFault(ScenarioModel):
    """A fault on the bench-board link between two mission times, in one direction or both. A scenario with
    link faults is paced in real time (they are wall-clock effects: a board's failsafe counts real time)."""

    kind: Literal["loss", "latency", "corruption", "outage"]
    direction: Literal["to_board", "from_board", "both"] = "both"
    start_s: MissionTime = 0.0
    end_s: UntilEnd = math.inf
    probability: float = Field(0.0, ge=0, le=1, description="loss: chance that a frame starts a loss burst")
    burst_frames: int = Field(1, ge=1, description="loss: frames lost together")
    delay_ms: float = Field(0.0, ge=0, description="latency")
    jitter_ms: float = Field(0.0, ge=0, description="latency: uniform, +-")
    byte_error_rate: float = Field(0.0, ge=0, le=1, description="corruption: chance per byte of a flipped bit")

    @model_validator(mode="after")
    def _says_how_much(self) -> LinkFault:
        needed = {"loss": self.probability, "latency": self.delay_ms + self.jitter_ms,
                  "corruption": self.byte_error_rate, "outage": 1.0}[self.kind]
        if needed <= 0:
            field = {"loss": "probability", "latency": "delay_ms", "corruption": "byte_error_rate"}[self.kind]
            raise ValueError(f"a {self.kind} fault needs {field} > 0")
        return self


class Faults(ScenarioModel):
    motors: list[MotorFault] = Field(default_factory=list)
    sensors: list[SensorFault] = Field(default_factory=list)
    link: list[LinkFault] = Field(default_factory=list)
    ground_station: list[GroundStationLoss] = Field(default_factory=list, max_length=100)


class Board(ScenarioModel):
    """Settings for the built-in emulator (ignored by a real board): controller, airframe, gains, ..."""

    controller: ControllerName = "smarc"
    airframe: AirframeName | None = None  # default: the vehicle preset
    state_source: Literal["estimator", "truth"] = "estimator"
    config: dict[str, Any] = Field(default_factory=dict, description="any further EmulatorConfig fields")
    params: dict[str, float] = Field(default_factory=dict, description=(
        "PX4 parameters for any board (failsafe actions and thresholds): the emulator's at start-up, PX4's at "
        "start-up when the bench starts it and through PARAM_SET, read back, before arming"))

    @field_validator("config")
    @classmethod
    def _is_emulator_config(cls, config: dict[str, Any], info: ValidationInfo) -> dict[str, Any]:
        """Validated against the emulator's own schema now, not by the emulator after the run has started."""
        chosen = {key: info.data[key] for key in ("airframe", "controller", "state_source") if info.data.get(key)}
        build_config({**chosen, **config})
        return config


class Telemetry(ScenarioModel):
    rates_hz: dict[ChannelName, Annotated[float, Field(gt=0, le=MAX_RATE_HZ)]] = Field(default_factory=dict)


class Bounds(ScenarioModel):
    max_error_m: ErrorBound | None = None  # m, on all axes or per axis
    max_attitude_error_deg: PositiveFloat | None = None
    min_realtime_factor: PositiveFloat | None = None
    # behaviour, judged on the truth and on what the board reported, whoever flies
    mission_completed: bool | None = None  # every item of the planned mission reached, in order
    home_within_m: Length | None = None  # where the vehicle came to rest, horizontally from home
    max_cross_track_m: Length | None = None  # from the planned leg being flown
    disarmed_by_s: MissionTime | None = None  # disarmed on the ground by this mission time (s after take-off)
    max_altitude_m: Length | None = None  # height above home, the whole flight
    modes_seen: list[PX4ModeName] | None = None  # PX4's modes (HEARTBEAT.custom_mode), each at least once
    failsafe: FailsafeExpected | None = None  # the board's reaction to a trigger (hil.scenario.failsafe)
    no_failsafe: bool | None = None  # never in a failsafe action while armed (HEARTBEAT MAV_STATE_CRITICAL)


class Expect(Bounds):
    """Pass/fail bounds. `px4` replaces any of them when PX4 flies (SITL, HITL rehearsal, a Pixhawk): its
    estimator is not the emulator's, and a bound must follow from what the flying estimator can achieve."""

    settle_s: MissionTime = 5.0
    px4: Bounds | None = None

    def for_board(self, px4: bool) -> Expect:
        if not px4 or self.px4 is None:
            return self
        return self.model_copy(update={name: getattr(self.px4, name) for name in self.px4.model_fields_set})


Loc = tuple[str | int, ...]


def _models(model: BaseModel, loc: Loc = ()) -> Iterator[tuple[Loc, BaseModel]]:
    """Every model inside `model` (itself included), with its location, through fields, lists and tuples."""
    yield loc, model
    for name in type(model).model_fields:
        value = getattr(model, name)
        items = enumerate(value) if isinstance(value, (list, tuple)) else [(None, value)]
        for index, item in items:
            if isinstance(item, BaseModel):
                yield from _models(item, (*loc, name) if index is None else (*loc, name, index))


def _check(loc: Loc, value: Any, reason: str) -> InitErrorDetails:
    return InitErrorDetails(type=PydanticCustomError(CHECK_ERROR, "{reason}", {"reason": reason}), loc=loc,
                            input=value)


class Scenario(ScenarioModel):
    name: str = Field(min_length=1, max_length=100, pattern=r"^[A-Za-z0-9_.-]+$")
    description: str = ""
    duration_s: Duration = 30.0
    rate_hz: float = Field(250.0, ge=50, le=2000)
    seed: int = Field(0, ge=0, le=2**63 - 1)
    vehicle: Vehicle = Vehicle()
    home: Home = Home()
    reference: Reference = HoverRef(type="hover")
    wind: Wind = Wind()
    disturbance: Disturbance = Disturbance()
    payload: list[PayloadStep] = Field(default_factory=list)
    sensors: SensorsConfig = SensorsConfig()
    faults: Faults = Faults()
    board: Board = Board()
    telemetry: Telemetry = Telemetry()
    battery: Battery | None = None  # the plant's pack, and BATTERY_STATUS to the board
    manual_control: ManualControl | None = None  # sticks, as a ground station's joystick sends them
    pilot: PilotSpec = BenchPilotSpec()
    end: End | None = None  # how the run ends: one of ENDS[pilot.type], by default the first
    expect: Expect | None = None
    plant: str | None = Field(None, description="the plant's mapping file (docs/plant.md), relative to the scenario "
                                                "file; none: our own FMU with the vehicle preset's rotors")

    @field_validator("plant")
    @classmethod
    def _from_the_scenario_file(cls, plant: str | None, info: ValidationInfo) -> str | None:
        """A relative path is the scenario file's (the loader gives its folder); kept absolute from then on."""
        if plant is None:
            return None
        folder = (info.context or {}).get(SCENARIO_DIR, Path.cwd())
        return str((Path(folder) / plant).resolve())

    @model_validator(mode="after")
    def _consistent(self, info: ValidationInfo) -> Scenario:
        """The checks across fields, each a separate error at its own field (the plant's files are not read
        for a scenario recorded elsewhere: context READ_PLANT False)."""
        resolve_end(self)
        errors = [*self._timing_errors(), *self._expression_errors(),
                  *(_check(*problem) for problem in pilot_problems(self)),
                  *self._payload_errors(), *self._reference_errors(),
                  *(_check(*problem) for problem in failsafe_problems(self))]
        if (info.context or {}).get(READ_PLANT, True):
            errors += [_check(loc, value, reason) for loc, value, reason in plant_problems(self)]
        if errors:
            raise ValidationError.from_exception_data(type(self).__name__, errors)
        return self

    def _timing_errors(self) -> Iterator[InitErrorDetails]:
        """Every mission-clock time before the end of the mission; every interval ending after its start."""
        end = self.duration_s
        for loc, model in _models(self):
            values = {name: getattr(model, name) for name in type(model).model_fields}
            for name in MISSION_TIMES:
                if name in values and values[name] >= end:
                    yield _check((*loc, name), values[name], f"{name} = {values[name]:g} s is not within the mission "
                                                             f"(duration_s = {end:g} s); "
                                                             f"expected a time before {end:g} s")
            if "start_s" in values and "end_s" in values and values["end_s"] <= values["start_s"]:
                yield _check((*loc, "end_s"), values["end_s"], f"ends at {values['end_s']:g} s, not after it starts "
                                                               f"(start_s = {values['start_s']:g} s); "
                                                               "expected end_s > start_s")

    def _expression_errors(self) -> Iterator[InitErrorDetails]:
        """Each expression evaluated at the start, the middle and the end of the mission."""
        times = (0.0, self.duration_s / 2, self.duration_s)
        for name in ("force_ned", "torque_frd"):
            for item in getattr(self.disturbance, name):
                try:
                    compile_expression(item, sample_times=times)
                except ExpressionError as exc:
                    yield _check(("disturbance", name), item, str(exc))

    def _payload_errors(self) -> Iterator[InitErrorDetails]:
        """Two steps at one time must agree on the mass: which one holds would be the file's order, not its intent."""
        first: dict[float, tuple[int, float]] = {}
        for index, step in enumerate(self.payload):
            earlier = first.setdefault(step.t_s, (index, step.mass_kg))
            if earlier[1] != step.mass_kg:
                yield _check(("payload", index, "mass_kg"), step.mass_kg,
                             f"payload[{earlier[0]}] sets {earlier[1]:g} kg at the same time (t_s = {step.t_s:g} s); "
                             "expected one mass per time")

    def _reference_errors(self) -> Iterator[InitErrorDetails]:
        """What the reference cannot fly within this mission, each at its own field."""
        for problem in self.reference.problems(self.duration_s):
            yield _check(("reference", problem.field), problem.value, problem.reason)
