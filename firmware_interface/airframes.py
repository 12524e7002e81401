"""The airframes by name: one table of each vehicle's mass, inertia, geometry and rotors.

The scenario's `vehicle.preset` turns an entry into the plant's parameters, the emulator's presets into
its nominal vehicle (what the flight code believes), and the schema and both CLIs offer the names. It
lives on the flight-code side because the emulator may import nothing of the bench.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, get_args

Spin = Literal["ccw", "cw"]  # seen from above
# Rotor layouts in PX4's motor order (HIL_ACTUATOR_CONTROLS index), each rotor's azimuth from the nose towards
# the right (degrees) at the arm length, and its spin: PX4's quad X (airframe 4001) and hexa X (airframe 6001,
# its CA_ROTOR0..5).
QUAD_X: tuple[tuple[float, Spin], ...] = ((45.0, "ccw"), (-135.0, "ccw"), (-45.0, "cw"), (135.0, "cw"))
HEXA_X: tuple[tuple[float, Spin], ...] = ((90.0, "cw"), (-90.0, "ccw"), (-30.0, "cw"), (150.0, "ccw"),
                                          (30.0, "ccw"), (-150.0, "cw"))


@dataclass(frozen=True)
class Airframe:
    """A multirotor airframe; inertia about the body FRD axes, `rotors` its layout (QUAD_X, HEXA_X)."""

    mass_kg: float
    inertia_frd_kg_m2: tuple[float, float, float]
    arm_length_m: float
    thrust_max_n: float  # one rotor at command 1
    thrust_curve_k: float  # T = T_max((1-k)u + k u²), as PX4's THR_MDL_FAC
    yaw_moment_coeff_m: float  # rotor drag torque per newton of thrust
    motor_tau_s: float  # first-order rotor lag (0: ideal)
    reversible: bool  # commands -1..1 give thrust -T_max..T_max
    drag_coeff_frd_n_s_m: tuple[float, float, float]  # linear body drag against the air-relative velocity
    rotors: tuple[tuple[float, Spin], ...] = QUAD_X

    @property
    def rotor_count(self) -> int:
        return len(self.rotors)


AirframeName = Literal["inspection_quad", "paper_airframe", "inspection_hexa"]
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
    # The inspection quad's body and rotors as a hexa X (six of its 5 N rotors on its 0.25 m arms): the same
    # vehicle but for the rotors, so that a hexa flight compares with a quad flight, and one rotor can fail.
    "inspection_hexa": Airframe(mass_kg=1.0, inertia_frd_kg_m2=(0.011, 0.011, 0.021), arm_length_m=0.25,
                                thrust_max_n=5.0, thrust_curve_k=0.5, yaw_moment_coeff_m=0.016, motor_tau_s=0.02,
                                reversible=False, drag_coeff_frd_n_s_m=(0.25, 0.25, 0.35), rotors=HEXA_X),
}
assert tuple(AIRFRAMES) == AIRFRAME_NAMES
