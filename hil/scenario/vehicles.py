"""Plant parameter sets behind the scenario's `vehicle.preset`."""

from __future__ import annotations

import math

from firmware_interface.airframes import AIRFRAMES, Airframe
from plant_fmu.variables import PARAMETER_DEFAULTS

# Rotor aerodynamics of the inspection quad, from RotorPy's AscTec Hummingbird parameter set (Folk, Paulos
# and Kumar, "RotorPy", 2023: mass 0.5 kg, arm 0.17 m, rotor radius 0.10 m, k_eta = 5.57e-6 N/(rad/s)^2,
# rotor drag k_d = 1.19e-4 and induced inflow k_z = 2.32e-4 N/((rad/s)(m/s)), taken there from the
# identification of Svacha et al., ICUAS 2017, reduced tenfold by RotorPy's authors; parasitic drag
# c_D = 0.5e-2, 0.5e-2, 1e-2 N/(m/s)^2 on x, y, z; flapping 0; no translational lift term).
# Scaling: the same rotor (k_eta, k_d, k_z kept), run up to our 5 N, so w_max = sqrt(5 / k_eta); body
# C_d*A = 2 c_D / rho, scaled with the frontal area, (0.25 / 0.17)^2 for our 0.25 m arms.
_SOURCE_K_ETA = 5.57e-6
_SOURCE_C_D = (0.5e-2, 0.5e-2, 1e-2)
_AREA_SCALE = (0.25 / 0.17) ** 2
_RHO = 1.225
INSPECTION_QUAD_AERO: dict[str, float] = {
    "rotor_speed_max": math.sqrt(5.0 / _SOURCE_K_ETA),
    "rotor_drag_coeff": 1.19e-4,
    "induced_inflow_coeff": 2.32e-4,
    "translational_lift_coeff": 0.0,
    "flapping_coeff": 0.0,
    **{f"parasitic_drag_area_{axis}": 2 * c_d / _RHO * _AREA_SCALE
       for axis, c_d in zip("xyz", _SOURCE_C_D, strict=True)},
}
# Every aerodynamic term off (the plant as it was before rotor aerodynamics): for comparisons.
NO_ROTOR_AERO: dict[str, float] = {name: 0.0 for name in INSPECTION_QUAD_AERO if name != "rotor_speed_max"}



def fmu_parameters(airframe: Airframe) -> dict[str, float]:
    """An airframe in the FMU's parameter names and units."""
    inertia, drag = airframe.inertia_frd_kg_m2, airframe.drag_coeff_frd_n_s_m
    return {"mass": airframe.mass_kg, "Ixx": inertia[0], "Iyy": inertia[1], "Izz": inertia[2],
            "arm_length": airframe.arm_length_m, "thrust_max": airframe.thrust_max_n,
            "thrust_curve_k": airframe.thrust_curve_k, "motor_tau": airframe.motor_tau_s,
            "rotor_reversible": float(airframe.reversible), "yaw_moment_coeff": airframe.yaw_moment_coeff_m,
            "drag_coeff_x": drag[0], "drag_coeff_y": drag[1], "drag_coeff_z": drag[2]}


# The inspection quad flies RotorPy's rotor aerodynamics, and so do its rotors as a hexa; the paper airframe
# none (its model has none). The rotor count is the plant mapping's (plant_fmu/mappings), not a parameter here.
PLANT_PRESETS: dict[str, dict[str, float]] = {
    "inspection_quad": {**fmu_parameters(AIRFRAMES["inspection_quad"]), **INSPECTION_QUAD_AERO},
    "paper_airframe": fmu_parameters(AIRFRAMES["paper_airframe"]),
    "inspection_hexa": {**fmu_parameters(AIRFRAMES["inspection_hexa"]), **INSPECTION_QUAD_AERO},
}


def plant_parameters(preset: str, overrides: dict[str, float]) -> dict[str, float]:
    return {**PLANT_PRESETS[preset], **overrides}


def thrust_to_weight(parameters: dict[str, float], rotors: int, payload_kg: float = 0.0) -> float:
    """All `rotors` at full command over the weight of airframe and payload (our FMU's defaults under
    `parameters`): at 1 or below the vehicle cannot take off, let alone be controlled."""
    p = {**PARAMETER_DEFAULTS, **parameters}
    weight = (p["mass"] + payload_kg) * p["g"]
    return rotors * p["thrust_max"] / weight if weight > 0 else math.inf


def cell_open_circuit_v(soc: float) -> float:
    """One LiPo cell's open-circuit voltage at state of charge `soc` (M. Chen and G. A. Rincon-Mora, IEEE Trans.
    Energy Conversion 21(2), 2006), the curve our FMU's battery follows (docs/plant.md)."""
    return -1.031 * math.exp(-35 * soc) + 3.685 + 0.2156 * soc - 0.1178 * soc**2 + 0.3201 * soc**3


def hover_power_w(parameters: dict[str, float], rotors: int, payload_kg: float = 0.0) -> float:
    """The electrical power our FMU's pack delivers in a hover: each rotor gives T = m·g/n at the speed
    w = w_max·sqrt(T/T_max) against the drag torque k_m·T, so P = n·k_m·T·w / efficiency (docs/plant.md)."""
    p = {**PARAMETER_DEFAULTS, **parameters}
    thrust = (p["mass"] + payload_kg) * p["g"] / rotors
    speed = p["rotor_speed_max"] * math.sqrt(thrust / p["thrust_max"])
    return rotors * p["yaw_moment_coeff"] * thrust * speed / p["battery_efficiency"]


def pack_max_power_w(parameters: dict[str, float]) -> float:
    """The most power our FMU's pack can deliver at full charge besides its base current I_b: (I - I_b)(V - R·I) = P
    has a real root while P <= (V - R·I_b)^2 / (4R), with V = N·V_oc(1) and R = N·r."""
    p = {**PARAMETER_DEFAULTS, **parameters}
    volts, ohms = p["battery_cells"] * cell_open_circuit_v(1.0), p["battery_cells"] * p["battery_cell_resistance"]
    return math.inf if ohms == 0 else (volts - ohms * p["battery_base_current"]) ** 2 / (4 * ohms)
