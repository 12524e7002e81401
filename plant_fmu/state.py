"""The plant's outputs after a step, by quantity (SI; NED earth frame, FRD body frame): what the bench's
loop, sensors, metrics and recorder read, so that no index table of the output vector lives outside
`plant_fmu`."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from plant_fmu.variables import OUTPUTS, span

REAL_OUTPUT_NAMES: tuple[str, ...] = tuple(v.name for v in OUTPUTS if not v.boolean)
_POS, _VEL, _ACC = (span(REAL_OUTPUT_NAMES, f"{q}_n", 3) for q in ("pos", "vel", "acc"))
_Q, _RPY = span(REAL_OUTPUT_NAMES, "q_w", 4), span(REAL_OUTPUT_NAMES, "roll", 3)
_RATES, _FORCE = span(REAL_OUTPUT_NAMES, "rate_x", 3), span(REAL_OUTPUT_NAMES, "specific_force_x", 3)
_THRUSTS, _SPEEDS = span(REAL_OUTPUT_NAMES, "thrust_1", 4), span(REAL_OUTPUT_NAMES, "rotor_speed_1", 4)
_TORQUE = span(REAL_OUTPUT_NAMES, "torque_x", 3)
_THRUST_TOTAL, _MASS = REAL_OUTPUT_NAMES.index("thrust_total"), REAL_OUTPUT_NAMES.index("total_mass")


@dataclass(frozen=True, slots=True)
class PlantState:
    pos_ned: np.ndarray  # m
    vel_ned: np.ndarray  # m/s
    acc_ned: np.ndarray  # m/s², the body's acceleration in the earth frame
    q_wxyz: np.ndarray  # attitude, body FRD -> NED
    rpy: np.ndarray  # ZYX Euler roll, pitch, yaw, rad
    rates_frd: np.ndarray  # body rates, rad/s
    specific_force_frd: np.ndarray  # what an ideal accelerometer reads, m/s²: (0, 0, -g) at rest
    thrusts_n: np.ndarray  # per rotor
    rotor_speeds_rad_s: np.ndarray
    torque_frd: np.ndarray  # the rotors' torque on the body, N·m
    thrust_total_n: float
    total_mass_kg: float  # airframe + payload
    on_ground: bool

    @classmethod
    def from_outputs(cls, outputs: np.ndarray, on_ground: bool) -> PlantState:
        """From a vector in `Plant.OUTPUT_NAMES` order, which the state keeps (pass a copy)."""
        o = outputs
        return cls(o[_POS], o[_VEL], o[_ACC], o[_Q], o[_RPY], o[_RATES], o[_FORCE], o[_THRUSTS], o[_SPEEDS],
                   o[_TORQUE], float(o[_THRUST_TOTAL]), float(o[_MASS]), on_ground)
