"""A short hover of the plant in a plain loop: climb to an altitude on a PD loop and hold it.

This is a smoke flight of the FMU alone (no board, no sensors); `hil run` flies the real chain.
"""

from __future__ import annotations

import numpy as np

from plant_fmu.hover import rotor_command_for_thrust
from plant_fmu.plant import Plant
from plant_fmu.variables import PARAMETER_DEFAULTS as DEFAULTS


def fly_hover(seconds: float, altitude_m: float = 2.0, dt_s: float = 0.004) -> list[tuple[float, float, float]]:
    """Return (t, altitude, climb rate) once a second."""
    mass, g = DEFAULTS["mass"], DEFAULTS["g"]
    t_max, k = DEFAULTS["thrust_max"], DEFAULTS["thrust_curve_k"]
    rows: list[tuple[float, float, float]] = []
    with Plant() as plant:
        inputs = np.zeros(len(plant.input_names))
        health = [plant.input_index[f"motor_health_{i}"] for i in range(1, 5)]
        cmds = [plant.input_index[f"motor_cmd_{i}"] for i in range(1, 5)]
        inputs[health] = 1.0
        out = plant.outputs()
        i_d, i_vd = plant.output_index["pos_d"], plant.output_index["vel_d"]
        steps = round(seconds / dt_s)
        per_second = round(1 / dt_s)
        for n in range(steps):
            error = (-altitude_m) - out[i_d]
            accel_up = -(2.0 * error - 2.5 * out[i_vd])  # PD on altitude, ~1 s settling
            thrust_each = mass * (g + accel_up) / 4
            inputs[cmds] = rotor_command_for_thrust(max(thrust_each, 0.0), t_max, k)
            plant.set_inputs(inputs)
            out = plant.step(dt_s)
            if (n + 1) % per_second == 0:
                rows.append((plant.t, -out[i_d], -out[i_vd]))
    return rows
