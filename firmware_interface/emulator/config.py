"""The emulator's configuration: what firmware would hold in its parameters.

Nominal vehicle (the flight code's belief, not the plant's truth), the controller and its
gains, the state source, failsafe and estimator settings. Two presets match the bench's
airframes: `inspection_quad` (the default 1 kg quad) and `paper_airframe` (the paper's §4).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, create_model, field_validator

from firmware_interface.airframes import AIRFRAMES, Airframe, AirframeName, Spin
from firmware_interface.emulator.control.registry import PLUGINS, ControllerName
from firmware_interface.emulator.px4_params import PX4_PARAMS, unknown_names
from firmware_interface.geodesy import STANDARD_GRAVITY_M_S2


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)  # a NaN gain flies nowhere


_QUAD = AIRFRAMES["inspection_quad"]
MAX_ROTORS = 12  # PX4's control allocation takes up to 12 (CA_ROTOR0..11)


class Rotor(_Model):
    """Where one rotor sits (FRD, metres from the centre of gravity) and which way it turns, seen from above."""

    position_frd_m: tuple[float, float, float]
    spin: Spin


def rotor_layout(airframe: Airframe) -> tuple[Rotor, ...]:
    """The airframe's rotors at its arm length, in PX4's motor order."""
    arm = airframe.arm_length_m
    return tuple(Rotor(position_frd_m=(arm * math.cos(math.radians(az)), arm * math.sin(math.radians(az)), 0.0),
                       spin=spin) for az, spin in airframe.rotors)


class NominalVehicle(_Model):
    """The flight code's belief of the vehicle (default: the inspection quad), in the mixer's terms."""

    mass: float = Field(_QUAD.mass_kg, gt=0)
    Ixx: float = Field(_QUAD.inertia_frd_kg_m2[0], gt=0)
    Iyy: float = Field(_QUAD.inertia_frd_kg_m2[1], gt=0)
    Izz: float = Field(_QUAD.inertia_frd_kg_m2[2], gt=0)
    arm_length: float = Field(_QUAD.arm_length_m, gt=0)
    thrust_max: float = Field(_QUAD.thrust_max_n, gt=0, description="N per rotor at command 1")
    thrust_curve_k: float = Field(_QUAD.thrust_curve_k, ge=0, le=1)
    yaw_moment_coeff: float = Field(_QUAD.yaw_moment_coeff_m, gt=0)
    reversible: bool = Field(_QUAD.reversible, description="rotors take -1..1 (ideal actuators of the paper)")
    rotors: Annotated[tuple[Rotor, ...], Field(min_length=1, max_length=MAX_ROTORS)] = Field(
        rotor_layout(_QUAD), description="the mixer's rotors in PX4's motor order (the bench sends the plant's)")
    g: float = STANDARD_GRAVITY_M_S2


if TYPE_CHECKING:  # the fields are data (the registry); to a type checker any name is a gains model
    class Gains(_Model):
        def __getattr__(self, name: str) -> Any: ...
else:  # one field per registered controller, its gains model
    Gains = create_model("Gains", __base__=_Model, **{name: (p.gains, p.gains()) for name, p in PLUGINS.items()})


class EstimatorSettings(_Model):
    gps_delay_s: float = Field(0.12, ge=0, description="as EKF2_GPS_DELAY: the receiver's latency")
    attitude_gain: float = Field(0.5, ge=0, description="complementary filter correction, 1/s")
    heading_gain: float = Field(0.3, ge=0)
    gps_pos_gain_xy: float = Field(0.15, ge=0, le=1, description="share of a GPS position innovation taken per fix")
    gps_pos_gain_z: float = Field(0.02, ge=0, le=1)
    gps_vel_from_pos_gain: float = Field(0.08, ge=0, le=1,
                                         description="velocity correction per metre of position innovation")
    gps_vel_gain: float = Field(0.25, ge=0, le=1)
    baro_gain: float = Field(0.02, ge=0, le=1, description="share of the baro height innovation per sample")
    correction_spread_s: float = Field(0.2, ge=0, description="GPS corrections are applied smoothly over this time")
    settle_s: float = Field(2.0, ge=0, description="time with good data before arming is allowed")
    mag_epoch_year: float = 2026.0


class EmulatorConfig(_Model):
    airframe: AirframeName = "inspection_quad"
    controller: ControllerName = "smarc"
    vehicle: NominalVehicle = NominalVehicle()
    gains: Gains = Gains()
    state_source: Literal["estimator", "truth"] = "estimator"
    estimator: EstimatorSettings = EstimatorSettings()
    failsafe_s: float | None = Field(0.5, gt=0, description=(
        "no HIL_SENSOR this long of wall time while armed: disarm; null: never, for a bench in lockstep, whose stall "
        "stops the simulated clock too (as PX4 SITL's lockstep clock stops with its simulator's)"))
    system_id: int = Field(1, ge=1, le=255)
    lockstep: bool = True
    params: dict[str, float] = Field(default_factory=dict, description=(
        "PX4 parameters of the commander and navigator to start with, by PX4's name (e.g. MIS_TAKEOFF_ALT, "
        "RTL_RETURN_ALT); a ground station may change them in flight"))

    @field_validator("params")
    @classmethod
    def _known_params(cls, params: dict[str, float]) -> dict[str, float]:
        unknown = unknown_names(list(params))
        if unknown:
            raise ValueError(f"unknown parameter {unknown[0]!r:.40}: expected one of {', '.join(PX4_PARAMS)}")
        return params


# The inspection quad has ~1/11 of the paper airframe's inertia and 20 ms rotor lag: the attitude
# gains are scaled by the inertia ratio and its bandwidth lowered below the rotors' (our choice).
# It flies on noisy sensors, where the paper's pure gradient law drifts (S1ᵀū_s contains −c1|S1|²,
# which noise biases): SMARC adapts on a 0.2 s low-passed S1 with a 0.05 m/s dead-zone, m̂ in [0.5, 2.5] kg.
_INSPECTION_GAINS = {
    "smarc": {"c2": 0.4, "epsilon": 0.02, "lambda2": 14.0, "differentiator_bandwidth": 40.0,
              "adaptation_filter_s": 0.2, "adaptation_deadzone": 0.05, "mass_min": 0.5, "mass_max": 2.5},
    "smpid": {"c2": 0.4, "epsilon_att": 0.02, "lambda2": 14.0, "differentiator_bandwidth": 40.0,
              "kp_yaw": 16.0, "kd_yaw": 8.0, "ki_yaw": 2.0},
    "backstepping": {"k3": 10.0, "k4": 14.0, "differentiator_bandwidth": 40.0},
}


def nominal_vehicle(airframe: Airframe) -> dict[str, Any]:
    """An airframe as NominalVehicle fields (the rotor lag and drag are the plant's, not the mixer's)."""
    inertia = airframe.inertia_frd_kg_m2
    return {"mass": airframe.mass_kg, "Ixx": inertia[0], "Iyy": inertia[1], "Izz": inertia[2],
            "arm_length": airframe.arm_length_m, "thrust_max": airframe.thrust_max_n,
            "thrust_curve_k": airframe.thrust_curve_k, "yaw_moment_coeff": airframe.yaw_moment_coeff_m,
            "reversible": airframe.reversible, "rotors": [r.model_dump() for r in rotor_layout(airframe)]}


PRESETS: dict[str, dict[str, Any]] = {
    "inspection_quad": {"vehicle": nominal_vehicle(AIRFRAMES["inspection_quad"]), "gains": _INSPECTION_GAINS},
    "paper_airframe": {"vehicle": nominal_vehicle(AIRFRAMES["paper_airframe"]), "gains": {}},
    "inspection_hexa": {"vehicle": nominal_vehicle(AIRFRAMES["inspection_hexa"]), "gains": _INSPECTION_GAINS},
}


def _merge(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for key, value in over.items():
        out[key] = _merge(out[key], value) if isinstance(value, dict) and isinstance(out.get(key), dict) else value
    return out


def build_config(overrides: dict[str, Any] | None = None) -> EmulatorConfig:
    """An airframe preset (overrides['airframe'], default inspection_quad) with any field overridden."""
    overrides = overrides or {}
    airframe = overrides.get("airframe", "inspection_quad")
    if not isinstance(airframe, str) or airframe not in PRESETS:
        raise ValueError(f"unknown airframe {airframe!r:.80}: expected one of {', '.join(PRESETS)}")
    return EmulatorConfig.model_validate(_merge({"airframe": airframe, **PRESETS[airframe]}, overrides))


def load_config(path: Path | None, overrides: dict[str, Any] | None = None) -> EmulatorConfig:
    data = yaml.safe_load(path.read_text()) if path else {}
    return build_config(_merge(data or {}, overrides or {}))
