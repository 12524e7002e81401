"""The plant contract: what the bench drives and reads on any plant FMU, in the bench's units and frames.

SI inside; NED earth frame, FRD body frame, as PX4. A mapping file (plant_fmu.mapping) names the FMU's
variable for each port with its unit and frame; the bench converts. The table is docs/plant.md's.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from plant_fmu.units import Quantity

Direction = Literal["input", "output"]
FrameKind = Literal["earth", "body", "attitude", "none"]
PER_ROTOR = -1  # one variable per rotor, named in the mapping's rotor list
ANY_COUNT = -2  # a list of any length (one per battery cell)


@dataclass(frozen=True)
class Port:
    """One quantity the bench exchanges with the plant."""

    name: str
    direction: Direction
    size: int  # values, or PER_ROTOR / ANY_COUNT
    quantity: Quantity
    frame: FrameKind  # earth: NED in the bench; body: FRD; attitude: FRD -> NED
    required: bool
    meaning: str


def _in(name: str, size: int, quantity: Quantity, frame: FrameKind, meaning: str, required: bool = False) -> Port:
    return Port(name, "input", size, quantity, frame, required, meaning)


def _out(name: str, size: int, quantity: Quantity, frame: FrameKind, meaning: str, required: bool = False) -> Port:
    return Port(name, "output", size, quantity, frame, required, meaning)


INPUT_PORTS: tuple[Port, ...] = (
    _in("rotor_command", PER_ROTOR, "dimensionless", "none", "rotor command, 0 stopped to 1 full, in PX4's "
        "motor order (HIL_ACTUATOR_CONTROLS)", required=True),
    _in("rotor_health", PER_ROTOR, "dimensionless", "none", "thrust multiplier per rotor: 1 healthy, 0 failed"),
    _in("wind", 3, "speed", "earth", "wind velocity (the air's velocity over the ground)"),
    _in("force", 3, "force", "earth", "disturbance force at the centre of gravity"),
    _in("torque", 3, "torque", "body", "disturbance torque about the centre of gravity"),
    _in("payload_mass", 1, "mass", "none", "payload carried at the centre of gravity"),
    _in("battery_fault_cell", 1, "dimensionless", "none", "the failing cell, 1..N (0: none)"),
    _in("battery_fault_resistance", 1, "resistance", "none", "internal resistance the failing cell gains"),
    _in("battery_fault_voltage", 1, "voltage", "none", "open-circuit voltage the failing cell loses"),
)

OUTPUT_PORTS: tuple[Port, ...] = (
    _out("position", 3, "length", "earth", "position of the centre of gravity", required=True),
    _out("velocity", 3, "speed", "earth", "velocity over the ground", required=True),
    _out("acceleration", 3, "acceleration", "earth", "acceleration (derived from the specific force if absent)"),
    _out("attitude_quaternion", 4, "dimensionless", "attitude", "attitude as a unit quaternion"),
    _out("attitude_euler", 3, "angle", "attitude", "attitude as ZYX Euler angles roll, pitch, yaw"),
    _out("body_rates", 3, "angular_rate", "body", "angular velocity in the body frame", required=True),
    _out("specific_force", 3, "acceleration", "body", "what an ideal accelerometer reads: (0, 0, -g) at rest",
         required=True),
    _out("rotor_thrust", PER_ROTOR, "force", "none", "thrust of each rotor"),
    _out("rotor_speed", PER_ROTOR, "angular_rate", "none", "speed of each rotor"),
    _out("thrust_total", 1, "force", "none", "sum of the rotors' thrust"),
    _out("rotor_torque", 3, "torque", "body", "the rotors' torque on the body"),
    _out("total_mass", 1, "mass", "none", "airframe and payload"),
    _out("on_ground", 1, "boolean", "none", "resting on the ground (derived from the height if absent)"),
    _out("battery_voltage", 1, "voltage", "none", "pack voltage at the terminals"),
    _out("battery_current", 1, "current", "none", "pack current, positive discharging"),
    _out("battery_consumed", 1, "charge", "none", "charge drawn since the start"),
    _out("battery_remaining", 1, "dimensionless", "none", "state of charge, 1 full to 0 empty"),
    _out("cell_voltages", ANY_COUNT, "voltage", "none", "voltage of each cell at the terminals"),
)

# One of the attitude ports is required; the other is derived from it.
ATTITUDE_PORTS = ("attitude_quaternion", "attitude_euler")
PORTS: dict[str, Port] = {p.name: p for p in (*INPUT_PORTS, *OUTPUT_PORTS)}
# Ports named in the rotor list of a mapping rather than under inputs/outputs, by the rotor entry's key.
ROTOR_KEYS: dict[str, str] = {"command": "rotor_command", "health": "rotor_health", "thrust": "rotor_thrust",
                              "speed": "rotor_speed"}
