"""Plant parameter sets behind the scenario's `vehicle.preset`."""

from __future__ import annotations

# The FMU's defaults are the inspection quad. The paper's §4 airframe: arm 0.5 m, Ixx = Iyy = 0.121,
# Izz = 0.151 kg·m², 1 kg; "ideal motors": no lag, linear, reversible, 40 N each (sized for 5 kg),
# no drag — the paper applies thrust and torque directly and models no aerodynamic drag.
PLANT_PRESETS: dict[str, dict[str, float]] = {
    "inspection_quad": {},
    "paper_airframe": {"mass": 1.0, "Ixx": 0.121, "Iyy": 0.121, "Izz": 0.151, "arm_length": 0.5,
                       "thrust_max": 40.0, "thrust_curve_k": 0.0, "motor_tau": 0.0, "rotor_reversible": 1.0,
                       "yaw_moment_coeff": 0.05, "drag_coeff_x": 0.0, "drag_coeff_y": 0.0, "drag_coeff_z": 0.0},
}


def plant_parameters(preset: str, overrides: dict[str, float]) -> dict[str, float]:
    return {**PLANT_PRESETS[preset], **overrides}
