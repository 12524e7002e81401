"""The scenario file, as a typed schema. Every field has a default except the name."""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, create_model, field_validator, model_validator

from hil.scenario.expressions import compile_expression
from hil.sensors.faults import SensorFault
from hil.sensors.suite import SensorsConfig
from plant_fmu.variables import PARAMETER_NAMES

Vec3 = tuple[float, float, float]
PositiveFloat = Annotated[float, Field(gt=0)]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid")


_POSITIVE = {"mass", "Ixx", "Iyy", "Izz", "arm_length", "thrust_max", "integration_step", "rotor_speed_max"}
_NON_NEGATIVE = {"rotor_drag_coeff", "induced_inflow_coeff", "translational_lift_coeff", "flapping_coeff",
                 "parasitic_drag_area_x", "parasitic_drag_area_y", "parasitic_drag_area_z", "air_density"}


def _parameter_field(name: str) -> Any:
    if name in _POSITIVE:
        return Field(None, gt=0)
    return Field(None, ge=0) if name in _NON_NEGATIVE else None


_VehicleParameters = create_model(  # one optional field per FMU parameter, so a typo names its own key
    "_VehicleParameters",
    __config__=ConfigDict(extra="forbid"),
    **{name: (float | None, _parameter_field(name)) for name in PARAMETER_NAMES},
)


class Vehicle(_VehicleParameters):  # type: ignore[misc, valid-type]
    """A plant preset plus overrides of any FMU parameter (mass, Ixx, thrust_max, ...)."""

    preset: Literal["inspection_quad", "paper_airframe"] = "inspection_quad"

    @property
    def overrides(self) -> dict[str, float]:
        return {name: value for name in PARAMETER_NAMES if (value := getattr(self, name)) is not None}


class Home(_Model):
    lat_deg: float = Field(47.397742, ge=-90, le=90)
    lon_deg: float = Field(8.545594, ge=-180, le=180)
    alt_msl_m: float = 488.0


class HoverRef(_Model):
    type: Literal["hover"]
    altitude_m: PositiveFloat = 10.0
    north_m: float = 0.0
    east_m: float = 0.0
    yaw_deg: float = 0.0


class HelixRef(_Model):
    type: Literal["helix"]
    radius_m: PositiveFloat = 1.0
    angular_rate: float = 0.5
    climb_rate: float = 1.0
    yaw_deg: float = 30.0
    altitude_m: PositiveFloat = 10.0
    ramp_s: float = Field(2.0, ge=0)


class WaypointsRef(_Model):
    type: Literal["waypoints"]
    points_ned: list[Vec3] = Field(min_length=2)
    speed: PositiveFloat = 2.0
    dwell_s: float = Field(0.0, ge=0)
    yaw_deg: float | None = None


class PatrolRef(_Model):
    type: Literal["patrol"]
    line_start_ned: Vec3
    line_end_ned: Vec3
    standoff_m: PositiveFloat = 5.0
    altitude_m: PositiveFloat = 10.0
    speed: PositiveFloat = 3.0
    dwell_s: float = Field(2.0, ge=0)
    passes: int = Field(2, ge=1)


Reference = Annotated[HoverRef | HelixRef | WaypointsRef | PatrolRef, Field(discriminator="type")]


class Gust(_Model):
    start_s: float = Field(ge=0)
    duration_s: PositiveFloat
    peak_ned: Vec3


class Turbulence(_Model):
    intensity: Literal["light", "moderate", "severe"] = "light"
    altitude_m: PositiveFloat = 10.0
    airspeed_m_s: PositiveFloat = 5.0


class Wind(_Model):
    steady_ned: Vec3 = (0.0, 0.0, 0.0)
    gusts: list[Gust] = Field(default_factory=list)
    turbulence: Turbulence | None = None


class Disturbance(_Model):
    """Expressions of t (s): force in NED (N), torque in FRD (N·m)."""

    force_ned: tuple[str | float, str | float, str | float] = (0.0, 0.0, 0.0)
    torque_frd: tuple[str | float, str | float, str | float] = (0.0, 0.0, 0.0)

    @field_validator("force_ned", "torque_frd")
    @classmethod
    def _compiles(cls, value: tuple[str | float, ...]) -> tuple[str | float, ...]:
        for item in value:
            compile_expression(item)
        return value


class PayloadStep(_Model):
    t_s: float = Field(ge=0)
    mass_kg: float = Field(ge=0)


class MotorFault(_Model):
    motor: int = Field(ge=1, le=4)
    start_s: float = Field(ge=0)
    end_s: float = math.inf
    health: float = Field(ge=0, le=1, description="thrust multiplier while the fault lasts")


class LinkFault(_Model):
    """A fault on the bench-board link between two mission times, in one direction or both. A scenario with
    link faults is paced in real time (they are wall-clock effects: a board's failsafe counts real time)."""

    kind: Literal["loss", "latency", "corruption", "outage"]
    direction: Literal["to_board", "from_board", "both"] = "both"
    start_s: float = Field(0.0, ge=0)
    end_s: float = math.inf
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
        if self.end_s <= self.start_s:
            raise ValueError(f"end_s ({self.end_s:g}) must be after start_s ({self.start_s:g})")
        return self


class Faults(_Model):
    motors: list[MotorFault] = Field(default_factory=list)
    sensors: list[SensorFault] = Field(default_factory=list)
    link: list[LinkFault] = Field(default_factory=list)


class Board(_Model):
    """Settings for the built-in emulator (ignored by a real board): controller, airframe, gains, ..."""

    controller: Literal["smarc", "smpid", "backstepping"] = "smarc"
    airframe: Literal["inspection_quad", "paper_airframe"] | None = None  # default: the vehicle preset
    state_source: Literal["estimator", "truth"] = "estimator"
    config: dict[str, Any] = Field(default_factory=dict, description="any further EmulatorConfig fields")


class Telemetry(_Model):
    rates_hz: dict[str, PositiveFloat] = Field(default_factory=dict)


class Bounds(_Model):
    max_error_m: float | tuple[float, float, float] | None = None
    max_attitude_error_deg: PositiveFloat | None = None
    min_realtime_factor: PositiveFloat | None = None


class Expect(Bounds):
    """Pass/fail bounds. `px4` replaces any of them when PX4 flies (SITL, HITL rehearsal, a Pixhawk): its
    estimator is not the emulator's, and a bound must follow from what the flying estimator can achieve."""

    settle_s: float = Field(5.0, ge=0)
    px4: Bounds | None = None

    def for_board(self, px4: bool) -> Expect:
        if not px4 or self.px4 is None:
            return self
        return self.model_copy(update=self.px4.model_dump(exclude_unset=True))


class Scenario(_Model):
    name: str = Field(min_length=1, pattern=r"^[A-Za-z0-9_.-]+$")
    description: str = ""
    duration_s: PositiveFloat = 30.0
    rate_hz: float = Field(250.0, ge=50, le=2000)
    seed: int = 0
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
    end: Literal["land", "disarm"] = "land"  # after the mission: land then disarm, or disarm where it is
    expect: Expect | None = None
