"""The recording's and the live views' channels: one typed model per channel, its JSON Schema generated
from the model, every field described with its frame and unit.

The loop builds plain dicts (cheap, orjson); the models exist so that a viewer gets a field list, types
and units, and so that a test can validate every recorded message against its channel's schema.
Quaternions are scalar-first (w, x, y, z) and rotate body FRD into earth NED; angles are ZYX Euler of
FRD relative to NED, in radians; positions are metres in the bench's local NED frame (origin at home).
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

import orjson
from pydantic import BaseModel, ConfigDict, Field

from firmware_interface.emulator.config import MAX_ROTORS
from firmware_interface.emulator.control.registry import INTERNAL_KEYS

Vec3 = Annotated[list[float], Field(min_length=3, max_length=3)]
Quat = Annotated[list[float], Field(min_length=4, max_length=4)]
PhaseName = Literal["preflight", "offboard", "takeoff", "mission", "landing", "disarming", "grounded", "done"]


def _f(description: str) -> Any:
    return Field(description=description)


class _Sample(BaseModel):
    model_config = ConfigDict(extra="forbid")
    t_us: int = Field(ge=0, description="bench (simulated) time of the step, µs since the start of the run")


class State(_Sample):
    """The plant's true state at the end of the step."""

    pos_ned: Vec3 = _f("true position, local NED, m")
    vel_ned: Vec3 = _f("true velocity, NED, m/s")
    acc_ned: Vec3 = _f("true acceleration, NED, m/s²")
    q_wxyz: Quat = _f("true attitude, quaternion FRD → NED, scalar first")
    rpy: Vec3 = _f("true roll, pitch, yaw (ZYX Euler of FRD in NED), rad")
    rates_frd: Vec3 = _f("true body rates, FRD, rad/s")
    thrust_total: float = _f("sum of the rotor thrusts, N")
    total_mass: float = _f("vehicle plus payload mass, kg")
    on_ground: bool = _f("the plant's ground contact is active")
    phase: PhaseName = _f("the bench's phase of the flight")
    mission_t: float | None = _f("mission time, s (negative during take-off; None before the take-off is planned)")


class Reference(_Sample):
    """The reference the bench streams to the board (truth frame)."""

    pos_ned: Vec3 = _f("reference position, local NED, m")
    vel_ned: Vec3 = _f("reference velocity, NED, m/s")
    acc_ned: Vec3 = _f("reference acceleration, NED, m/s²")
    yaw: float = _f("reference yaw, rad (0 = north, positive clockwise seen from above)")


class Imu(_Sample):
    """What the board's HIL_SENSOR carries from the accelerometer and gyroscope."""

    accel_frd: Vec3 = _f("measured specific force, FRD, m/s² ((0, 0, −9.81) at rest)")
    gyro_frd: Vec3 = _f("measured body rates, FRD, rad/s")


class Gps(_Sample):
    """A HIL_GPS fix as sent."""

    measured_t_us: int = _f("time the fix describes, µs (earlier than t_us by the receiver delay)")
    lat_deg: float = _f("WGS-84 latitude, degrees")
    lon_deg: float = _f("WGS-84 longitude, degrees")
    alt_msl_m: float = _f("altitude above mean sea level, m")
    vel_ned: Vec3 = _f("measured velocity, NED, m/s")
    eph_m: float = _f("horizontal accuracy (1 σ), m")
    epv_m: float = _f("vertical accuracy (1 σ), m")
    fix_type: int = _f("GPS fix type (MAVLink GPS_FIX_TYPE: 0 none … 3 3D)")
    satellites: int = _f("satellites visible")


class Baro(_Sample):
    pressure_pa: float = _f("static pressure, Pa")
    temperature_degc: float = _f("air temperature, °C")
    pressure_alt_m: float = _f("pressure altitude, m (ISA)")


class Mag(_Sample):
    mag_frd_t: Vec3 = _f("measured magnetic field, FRD, tesla")


class Actuators(_Sample):
    """The board's HIL_ACTUATOR_CONTROLS as the plant applies them."""

    motors: Annotated[list[float], Field(min_length=1, max_length=MAX_ROTORS)] = _f(
        "normalised motor commands 0..1 of the plant's rotors, in PX4's motor order (a quad X: front-right, "
        "rear-left, front-left, rear-right)")
    armed: bool = _f("the board reports itself armed")


class Environment(_Sample):
    """What the scenario's environment applied during the step."""

    wind_ned: Vec3 = _f("wind velocity (air relative to ground), NED, m/s")
    force_ned: Vec3 = _f("scripted external force, NED, N (aerodynamic forces are in the plant, not here)")
    torque_frd: Vec3 = _f("scripted external torque, FRD, N·m")
    payload_kg: float = _f("attached payload, kg")
    motor_health: Annotated[list[float], Field(min_length=1, max_length=MAX_ROTORS)] = _f(
        "thrust factor per motor, 1 healthy, 0 dead")


class Timing(_Sample):
    step_wall_us: float = _f("wall time of the step, µs")
    round_trip_us: float | None = _f("sensor frame sent → actuator reply received, µs (None if no reply)")
    start_monotonic_us: int = _f("the step's start on the machine's monotonic clock (CLOCK_MONOTONIC), µs: the "
                                 "clock of PX4's log on its HITL path and of cyclictest")


class Event(_Sample):
    text: str = _f("what happened (phase change, command, fault, board message)")


class AttitudeTarget(_Sample):
    """The board's ATTITUDE_TARGET: what its attitude loop is asked to hold."""

    q: Quat = _f("commanded attitude, quaternion FRD → NED, scalar first")
    rpy: Vec3 = _f("commanded roll, pitch, yaw (ZYX Euler of q), rad")
    thrust: float = _f("collective thrust command, normalised 0..1")


class Estimates(_Sample):
    """The board's DEBUG_FLOAT_ARRAY: the controller's internal states, named."""

    name: str = _f("the controller's name on the wire (MAVLink truncates it to 10 characters)")
    values: dict[str, float] = Field(description=(
        "the controller's internal states by name; "
        + "; ".join(f"{c}: {', '.join(keys)}" for c, keys in sorted(INTERNAL_KEYS.items()))
        + " (m_hat kg, d_hat N in NED, thrust_n N, sliding surfaces in m/s)"))


class Heartbeat(_Sample):
    armed: bool = _f("MAV_MODE_FLAG_SAFETY_ARMED is set")
    custom_mode: int = _f("autopilot-specific mode (PX4: main mode << 16 | sub mode << 24)")
    system_status: int = _f("MAV_STATE")


class StatusText(_Sample):
    severity: int = _f("MAV_SEVERITY (0 emergency … 7 debug)")
    text: str = _f("the board's message")


class CommandAck(_Sample):
    command: int = _f("MAV_CMD acknowledged")
    result: int = _f("MAV_RESULT (0 accepted)")


class LocalPositionNed(_Sample):
    """The board's own position estimate, in the board's local frame (its origin, not the bench's)."""

    pos_ned: Vec3 = _f("estimated position, board's local NED, m")
    vel_ned: Vec3 = _f("estimated velocity, NED, m/s")


class AttitudeEstimate(_Sample):
    rpy: Vec3 = _f("the board's estimated roll, pitch, yaw, rad")


class ExtendedSysState(_Sample):
    landed_state: int = _f("MAV_LANDED_STATE (1 on ground, 2 in air, 3 taking off, 4 landing)")


class MissionCurrent(_Sample):
    seq: int = _f("the mission item being flown (MISSION_CURRENT.seq)")
    total: int = _f("items in the mission (65535: none)")


class MissionItemReached(_Sample):
    seq: int = _f("the mission item just reached (PX4 repeats it ten times at 1 Hz)")


class Battery(_Sample):
    """The plant's battery as the BATTERY_STATUS sent at this step carries it (before MAVLink's rounding to mV, cA,
    mAh and whole percent), at the scenario's battery.rate_hz."""

    voltage_v: float = _f("pack voltage at the terminals, V")
    current_a: float = _f("pack current, A, positive discharging")
    consumed_c: float = _f("charge drawn since the start, C (mAh = C / 3.6)")
    remaining: float = _f("state of charge, 1 full … 0 empty")
    cell_voltages_v: list[float] = _f("each cell at the terminals, V (empty: the plant gives none)")


class ManualControl(_Sample):
    """The sticks of the MANUAL_CONTROL sent at this step (PX4's manual_control_setpoint: each in [-1, 1])."""

    pitch: float = _f("forward +")
    roll: float = _f("right +")
    throttle: float = _f("up +, 0 centred (MANUAL_CONTROL z = 500)")
    yaw: float = _f("clockwise seen from above +")


class LinkCounters(_Sample):
    """Telemetry only: the link's frame counters, once per second."""

    model_config = ConfigDict(extra="allow")


# channel name (topic without the "hil/" prefix) → its model
CHANNEL_MODELS: dict[str, type[_Sample]] = {
    "state": State, "reference": Reference, "sensors/imu": Imu, "sensors/gps": Gps, "sensors/baro": Baro,
    "sensors/mag": Mag, "actuators": Actuators, "environment": Environment, "timing": Timing,
    "events": Event, "board/attitude_target": AttitudeTarget, "board/estimates": Estimates,
    "board/heartbeat": Heartbeat, "board/statustext": StatusText, "board/command_ack": CommandAck,
    "board/local_position_ned": LocalPositionNed, "board/attitude": AttitudeEstimate,
    "board/extended_sys_state": ExtendedSysState, "board/mission_current": MissionCurrent,
    "board/mission_item_reached": MissionItemReached, "board/link": LinkCounters, "battery": Battery,
    "manual_control": ManualControl,
}
RECORDED_CHANNELS = tuple(c for c in CHANNEL_MODELS if c != "board/link")
# board message type (MAVLink name) → its channel
BOARD_CHANNEL = {"ATTITUDE_TARGET": "board/attitude_target", "DEBUG_FLOAT_ARRAY": "board/estimates",
                 "HEARTBEAT": "board/heartbeat", "STATUSTEXT": "board/statustext", "COMMAND_ACK": "board/command_ack",
                 "LOCAL_POSITION_NED": "board/local_position_ned", "ATTITUDE": "board/attitude",
                 "EXTENDED_SYS_STATE": "board/extended_sys_state", "MISSION_CURRENT": "board/mission_current",
                 "MISSION_ITEM_REACHED": "board/mission_item_reached"}
TOPIC_PREFIX = "hil/"


def schema_name(channel: str) -> str:
    return "hil." + CHANNEL_MODELS[channel].__name__


def json_schema(channel: str) -> bytes:
    """The channel's JSON Schema (draft 2020-12, as pydantic writes it), with a title and description."""
    model = CHANNEL_MODELS[channel]
    schema = model.model_json_schema()
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["title"] = schema_name(channel)
    return orjson.dumps(schema)
