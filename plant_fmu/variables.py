"""The plant FMU's public interface, as one table.

modelDescription.xml and the C header of value references are both generated from
this table, so the XML, the C code and the Python wrapper can never disagree.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

Causality = Literal["parameter", "input", "output"]
FmiType = Literal["Real", "Integer", "Boolean"]
MAX_ROTORS = 6  # hexa X; a quad X uses the first four of each per-rotor variable
MAX_CELLS = 14  # MAVLink BATTERY_STATUS: 10 cell voltages and 4 more in voltages_ext


@dataclass(frozen=True)
class Variable:
    """One FMI scalar variable; `vr` is its index in the table."""

    name: str
    causality: Causality
    unit: str
    description: str
    start: float | None = None
    type: FmiType = "Real"


def _p(name: str, start: float, unit: str, description: str) -> Variable:
    return Variable(name, "parameter", unit, description, start)


def _u(name: str, start: float, unit: str, description: str) -> Variable:
    return Variable(name, "input", unit, description, start)


def _y(name: str, unit: str, description: str, fmi_type: FmiType = "Real") -> Variable:
    return Variable(name, "output", unit, description, type=fmi_type)


# Defaults: a 1 kg inspection quad (arm 0.25 m, 4 x 5 N rotors) that hovers near
# mid-throttle: T_hover = 9.80665/4 = 2.45 N per rotor -> u ≈ 0.61 with k = 0.5.
PARAMETERS: tuple[Variable, ...] = (
    Variable("rotor_count", "parameter", "", "4: PX4's quad X (airframe 4001), 6: PX4's hexa X (airframe 6001)", 4,
             "Integer"),
    _p("mass", 1.0, "kg", "airframe mass without payload"),
    _p("Ixx", 0.011, "kg.m2", "inertia about body x (FRD)"),
    _p("Iyy", 0.011, "kg.m2", "inertia about body y (FRD)"),
    _p("Izz", 0.021, "kg.m2", "inertia about body z (FRD)"),
    _p("arm_length", 0.25, "m", "centre of gravity to rotor axis"),
    _p("thrust_max", 5.0, "N", "thrust of one rotor at command 1"),
    _p("thrust_curve_k", 0.5, "1", "T = T_max((1-k)u + k u^2), as PX4's THR_MDL_FAC"),
    _p("motor_tau", 0.02, "s", "rotor thrust first-order lag time constant (0 = ideal)"),
    _p("rotor_reversible", 0.0, "1", "1: commands -1..1 give thrust -T_max..T_max (ideal actuators)"),
    _p("yaw_moment_coeff", 0.016, "m", "rotor drag torque per newton of thrust"),
    _p("drag_coeff_x", 0.25, "N.s/m", "linear drag along body x against air-relative velocity"),
    _p("drag_coeff_y", 0.25, "N.s/m", "linear drag along body y against air-relative velocity"),
    _p("drag_coeff_z", 0.35, "N.s/m", "linear drag along body z against air-relative velocity"),
    # Rotor aerodynamics, per rotor at its hub's air velocity (body FRD, rotation included); all zero by
    # default, which leaves the model exactly as without them.
    _p("rotor_speed_max", 1000.0, "rad/s", "rotor speed at thrust_max: T = k_eta w^2 with k_eta = thrust_max/w_max^2"),
    _p("rotor_drag_coeff", 0.0, "N.s/(m.rad)", "rotor drag (H-force) in the rotor plane: F = -k_d w v_inplane"),
    _p("induced_inflow_coeff", 0.0, "N.s/(m.rad)", "thrust lost per climb speed through the disc: -k_z w v_climb"),
    _p("translational_lift_coeff", 0.0, "N.s2/m2", "thrust gained with edgewise air speed: +k_h |v_inplane|^2"),
    _p("flapping_coeff", 0.0, "N.s/rad", "blade flapping moment: M = -k_flap w (v_inplane x z_body)"),
    _p("parasitic_drag_area_x", 0.0, "m2", "body C_d*A along x: F = -1/2 rho C_d A |v_air| v_air_x"),
    _p("parasitic_drag_area_y", 0.0, "m2", "body C_d*A along y"),
    _p("parasitic_drag_area_z", 0.0, "m2", "body C_d*A along z"),
    _p("air_density", 1.225, "kg/m3", "air density for the parasitic drag (ISA sea level)"),
    _p("g", 9.80665, "m/s2", "gravity, +down in NED"),
    _p("ground_height", 0.0, "m", "ground altitude above the NED origin (ground plane at pos_d = -ground_height)"),
    _p("init_pos_n", 0.0, "m", "initial north position"),
    _p("init_pos_e", 0.0, "m", "initial east position"),
    _p("init_pos_d", 0.0, "m", "initial down position"),
    _p("init_yaw", 0.0, "rad", "initial heading"),
    _p("integration_step", 0.001, "s", "fixed RK4 step inside each doStep"),
    # Battery (docs/plant.md): LiPo cells in series, Chen and Rincon-Mora's open-circuit voltage curve, a
    # series resistance; current from the rotors' shaft power k_m T w over an efficiency, plus a base load.
    Variable("battery_cells", "parameter", "", f"cells in series, 1..{MAX_CELLS}", 4, "Integer"),
    _p("battery_capacity", 5.0, "A.h", "charge of the full pack"),
    _p("battery_initial_soc", 1.0, "1", "state of charge at the start, 0..1"),
    _p("battery_cell_resistance", 0.012, "Ohm", "series resistance of one cell"),
    _p("battery_efficiency", 0.7, "1", "rotor shaft power over electrical power (motors and controllers)"),
    _p("battery_base_current", 0.0, "A", "current drawn besides the rotors (avionics, payload)"),
)

INPUTS: tuple[Variable, ...] = (
    *(_u(f"motor_cmd_{i}", 0.0, "1", f"rotor {i} command 0..1 (PX4's motor order)") for i in range(1, 7)),
    *(_u(f"motor_health_{i}", 1.0, "1", f"rotor {i} thrust multiplier (1 = healthy)") for i in range(1, 7)),
    _u("wind_n", 0.0, "m/s", "wind velocity north"),
    _u("wind_e", 0.0, "m/s", "wind velocity east"),
    _u("wind_d", 0.0, "m/s", "wind velocity down"),
    _u("f_dist_n", 0.0, "N", "disturbance force north"),
    _u("f_dist_e", 0.0, "N", "disturbance force east"),
    _u("f_dist_d", 0.0, "N", "disturbance force down"),
    _u("tau_dist_x", 0.0, "N.m", "disturbance torque about body x (FRD)"),
    _u("tau_dist_y", 0.0, "N.m", "disturbance torque about body y (FRD)"),
    _u("tau_dist_z", 0.0, "N.m", "disturbance torque about body z (FRD)"),
    _u("payload_mass", 0.0, "kg", "payload at the centre of gravity"),
    _u("battery_fault_cell", 0.0, "1", "the failing cell, 1..battery_cells (0: none)"),
    _u("battery_fault_resistance", 0.0, "Ohm", "series resistance the failing cell gains"),
    _u("battery_fault_voltage", 0.0, "V", "open-circuit voltage the failing cell loses"),
)

OUTPUTS: tuple[Variable, ...] = (
    *(_y(f"pos_{a}", "m", f"position {a.upper()} (NED)") for a in "ned"),
    *(_y(f"vel_{a}", "m/s", f"velocity {a.upper()} (NED)") for a in "ned"),
    *(_y(f"acc_{a}", "m/s2", f"acceleration {a.upper()} (NED)") for a in "ned"),
    *(_y(f"q_{a}", "1", f"attitude quaternion {a} (body FRD to NED)") for a in "wxyz"),
    _y("roll", "rad", "ZYX Euler roll"),
    _y("pitch", "rad", "ZYX Euler pitch"),
    _y("yaw", "rad", "ZYX Euler yaw"),
    *(_y(f"rate_{a}", "rad/s", f"body rate about {a} (FRD)") for a in "xyz"),
    *(_y(f"specific_force_{a}", "m/s2", f"accelerometer reading {a} (FRD)") for a in "xyz"),
    *(_y(f"thrust_{i}", "N", f"rotor {i} thrust from the thrust curve and motor lag") for i in range(1, 7)),
    *(_y(f"rotor_speed_{i}", "rad/s", f"rotor {i} speed, from its thrust: sqrt(T/k_eta)") for i in range(1, 7)),
    _y("thrust_total", "N", "sum of rotor thrusts"),
    *(_y(f"torque_{a}", "N.m", f"rotor torque about body {a} (FRD)") for a in "xyz"),
    _y("total_mass", "kg", "mass + payload"),
    _y("on_ground", "", "resting on the ground plane", "Boolean"),
    _y("battery_voltage", "V", "pack voltage at the terminals"),
    _y("battery_current", "A", "pack current, positive discharging"),
    _y("battery_consumed", "A.h", "charge drawn since the start"),
    _y("battery_remaining", "1", "state of charge, 1 full .. 0 empty"),
    *(_y(f"cell_voltage_{i}", "V", f"cell {i} at the terminals (0 beyond battery_cells)") for i in range(1, 15)),
)

VARIABLES: tuple[Variable, ...] = PARAMETERS + INPUTS + OUTPUTS
VR: dict[str, int] = {v.name: i for i, v in enumerate(VARIABLES)}
PARAMETER_NAMES = tuple(v.name for v in PARAMETERS)


def span(names: tuple[str, ...], first: str, count: int) -> slice:
    """Where `count` consecutive variables starting at `first` sit in a vector ordered as `names`."""
    start = names.index(first)
    return slice(start, start + count)


PARAMETER_DEFAULTS: dict[str, float] = {v.name: v.start for v in PARAMETERS if v.start is not None}
INPUT_NAMES = tuple(v.name for v in INPUTS)
OUTPUT_NAMES = tuple(v.name for v in OUTPUTS)
