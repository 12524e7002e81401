"""The plant's outputs after a step, by quantity (SI; NED earth frame, FRD body frame): what the bench's
loop, sensors, metrics and recorder read, whatever FMU the mapping names. A quantity the plant does not
give is NaN; `battery` is None for a plant without one."""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple, Protocol

import numpy as np


class BatteryState(NamedTuple):
    """A tuple rather than a frozen dataclass: it is built every step, and this is four times cheaper."""

    voltage_v: float  # at the terminals
    current_a: float  # positive discharging
    consumed_c: float  # charge drawn since the start, coulombs (mAh = C / 3.6)
    remaining: float  # state of charge, 1 full .. 0 empty
    cell_voltages_v: np.ndarray  # at the terminals, per cell (empty: not given)


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
    battery: BatteryState | None = None  # None: the plant has no battery


class StepOutputs(Protocol):
    """What a step's frames are made from: the motion an ideal IMU, GPS and ground truth read, and the battery.
    A `PlantState` is one; so is `Plant.live()`, the plant's outputs read in place until its next step, which the
    bench's lockstep step sends its frames from before it copies them into the state it keeps."""

    @property
    def pos_ned(self) -> np.ndarray: ...

    @property
    def vel_ned(self) -> np.ndarray: ...

    @property
    def q_wxyz(self) -> np.ndarray: ...

    @property
    def rates_frd(self) -> np.ndarray: ...

    @property
    def specific_force_frd(self) -> np.ndarray: ...

    @property
    def battery(self) -> BatteryState | None: ...
