"""The airframes by name: one table of each vehicle's mass, inertia, geometry and rotors.

The scenario's `vehicle.preset` turns an entry into the plant's parameters, the emulator's presets into
its nominal vehicle (what the flight code believes), and the schema and both CLIs offer the names. It
lives on the flight-code side because the emulator may import nothing of the bench.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, get_args


@dataclass(frozen=True)
class Airframe:
    """A quad X airframe; inertia about the body FRD axes, rotors at 45° to them."""

    mass_kg: float
    inertia_frd_kg_m2: tuple[float, float, float]
    arm_length_m: float
    thrust_max_n: float  # one rotor at command 1
    thrust_curve_k: float  # T = T_max((1-k)u + k u²), as PX4's THR_MDL_FAC
    yaw_moment_coeff_m: float  # rotor drag torque per newton of thrust
    motor_tau_s: float  # first-order rotor lag (0: ideal)
    reversible: bool  # commands -1..1 give thrust -T_max..T_max
    drag_coeff_frd_n_s_m: tuple[float, float, float]  # linear body drag against the air-relative velocity


AirframeName = Literal["inspection_quad", "paper_airframe"]
AIRFRAME_NAMES: tuple[str, ...] = get_args(AirframeName)

AIRFRAMES: dict[str, Airframe] = {
    # A 1 kg inspection quad, 0.25 m arms, 4 × 5 N rotors: hovers near mid-throttle (2.45 N a rotor).
    "inspection_quad": Airframe(mass_kg=1.0, inertia_frd_kg_m2=(0.011, 0.011, 0.021), arm_length_m=0.25,
                                thrust_max_n=5.0, thrust_curve_k=0.5, yaw_moment_coeff_m=0.016, motor_tau_s=0.02,
                                reversible=False, drag_coeff_frd_n_s_m=(0.25, 0.25, 0.35)),
    # The paper's §4 airframe: arm 0.5 m, Ixx = Iyy = 0.121, Izz = 0.151 kg·m², 1 kg; "ideal motors" (no
    # lag, linear, reversible, 40 N each, sized for 5 kg) and no drag: the paper applies thrust and torque
    # directly and models no aerodynamic effect. The yaw moment coefficient is ours (the paper gives none).
    "paper_airframe": Airframe(mass_kg=1.0, inertia_frd_kg_m2=(0.121, 0.121, 0.151), arm_length_m=0.5,
                               thrust_max_n=40.0, thrust_curve_k=0.0, yaw_moment_coeff_m=0.05, motor_tau_s=0.0,
                               reversible=True, drag_coeff_frd_n_s_m=(0.0, 0.0, 0.0)),
}
assert tuple(AIRFRAMES) == AIRFRAME_NAMES
