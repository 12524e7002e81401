"""What every controller sees and returns, and the steps all three share.

Frames: NED earth, FRD body, ZYX Euler angles η = (roll, pitch, yaw). The paper writes its
laws with z up; here gravity is +g·e3 (down) and the thrust force is −u1·R·e3.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from firmware_interface.emulator.compiled import shared_maths
from firmware_interface.emulator.geometry import body_from_euler_torque, wrap_pi
from firmware_interface.geodesy import STANDARD_GRAVITY_M_S2

E3 = np.array((0.0, 0.0, 1.0))


@dataclass(frozen=True, eq=False)
class VehicleState:
    """The estimate the controller flies on (never the plant's truth, unless state_source is truth)."""

    pos_ned: np.ndarray
    vel_ned: np.ndarray
    eta: np.ndarray  # roll, pitch, yaw (rad)
    rates_frd: np.ndarray  # rad/s


@dataclass(frozen=True)
class Setpoint:
    pos_ned: np.ndarray
    vel_ned: np.ndarray
    acc_ned: np.ndarray
    yaw: float


@dataclass(frozen=True)
class ControlOutput:
    thrust_n: float  # u1, total
    torque_frd: np.ndarray  # body torques, N·m
    eta_cmd: np.ndarray  # commanded roll, pitch, yaw
    internals: Mapping[str, float] = field(default_factory=dict)  # estimates and sliding variables to publish


class Controller(Protocol):
    @property
    def name(self) -> str: ...  # read-only members: a class attribute of each controller satisfies them

    @property
    def internal_keys(self) -> tuple[str, ...]: ...  # the order of `internals` in DEBUG_FLOAT_ARRAY

    def update(self, state: VehicleState, setpoint: Setpoint, dt: float, adapt: bool = True) -> ControlOutput:
        """`adapt=False` holds adaptation and integrators (on the ground, before lift-off)."""
        ...

    def reset(self) -> None: ...


@dataclass(frozen=True)
class Nominal:
    """The nominal vehicle the flight code believes in (from its config, not from the plant)."""

    mass: float
    inertia: np.ndarray  # Ixx, Iyy, Izz
    g: float = STANDARD_GRAVITY_M_S2


@shared_maths
def attitude_from_force(force_ned: np.ndarray, yaw: float, max_tilt: float,
                        min_lift: float) -> tuple[float, float, float]:
    """Commanded roll, pitch and vertical force u_z for a desired thrust force (eqs. 26–29).

    The paper's u_s = u1·R·e3 points up; in NED the thrust force is −u1·R·e3, so the paper's
    equations apply to u = −force. Rotors cannot pull down: u_z is kept above `min_lift` (N),
    otherwise eqs. 28–29 divide by ~0 and flip the tilt command.
    """
    ux, uy, uz = -force_ned
    uz = max(uz, min_lift)
    c, s = math.cos(yaw), math.sin(yaw)
    pitch = math.atan((ux * c + uy * s) / uz)  # eq. 28
    roll = math.atan(math.cos(pitch) * (ux * s - uy * c) / uz)  # eq. 29
    pitch = max(-max_tilt, min(max_tilt, pitch))
    roll = max(-max_tilt, min(max_tilt, roll))
    return roll, pitch, uz


@shared_maths
def collective_thrust(uz: float, roll: float, pitch: float) -> float:
    """u1 = u_z / (cos θ cos γ) with the current attitude (the paper's actual control input)."""
    return uz / max(math.cos(roll) * math.cos(pitch), 0.5)


@shared_maths
def command_from_force(force_ned: np.ndarray, yaw: float, max_tilt: float, min_lift: float,
                       eta: np.ndarray) -> tuple[np.ndarray, float]:
    """(η_cmd, u1): the attitude that points the thrust along `force_ned` and the collective thrust that gives
    its vertical part at the present attitude η."""
    roll_cmd, pitch_cmd, uz = attitude_from_force(force_ned, yaw, max_tilt, min_lift)
    return np.array((roll_cmd, pitch_cmd, yaw)), collective_thrust(uz, eta[0], eta[1])


@shared_maths
def angle_error(eta: np.ndarray, eta_cmd: np.ndarray) -> np.ndarray:
    e = eta - eta_cmd
    e[2] = wrap_pi(e[2])
    return e


@shared_maths
def sat(x: np.ndarray, boundary: float) -> np.ndarray:
    """The saturation function that replaces sgn inside a boundary layer."""
    return np.clip(x / boundary, -1.0, 1.0)


@shared_maths
def body_torque(tau_euler: np.ndarray, eta: np.ndarray) -> np.ndarray:
    """The paper's τ lives in Euler coordinates (J η̈ + C η̇ = τ); the rotors apply τ_body = W⁻ᵀ τ."""
    return body_from_euler_torque(eta, tau_euler)


# A compiled control step returns one array: the collective thrust (N), the body torque (FRD, N·m), η_cmd, then the
# law's internals in the order of its `internal_keys`.
INTERNALS = 7


@shared_maths
def step_output(thrust_n: float, torque_frd: np.ndarray, eta_cmd: np.ndarray, internals: int) -> np.ndarray:
    """A step's output array with room for `internals` values after η_cmd."""
    out = np.empty(INTERNALS + internals)
    out[0] = thrust_n
    out[1:4] = torque_frd
    out[4:7] = eta_cmd
    return out


class InternalValues(Mapping[str, float]):
    """A compiled step's internals by name, read from its output array when asked: they are published at 50 Hz,
    and a dict of them built every step cost more than some laws."""

    __slots__ = ("_keys", "_values")

    def __init__(self, keys: tuple[str, ...], values: np.ndarray) -> None:
        if len(values) != len(keys):
            raise ValueError(f"{len(values)} internals for the {len(keys)} names {keys}")
        self._keys, self._values = keys, values

    def __getitem__(self, key: str) -> float:
        try:
            return float(self._values[self._keys.index(key)])
        except ValueError:
            raise KeyError(key) from None

    def __iter__(self) -> Iterator[str]:
        return iter(self._keys)

    def __len__(self) -> int:
        return len(self._keys)


def internals_in_order(internals: Mapping[str, float], keys: tuple[str, ...]) -> np.ndarray | list[float]:
    """The values under `keys`, in that order: a compiled step's output array itself when those are its names
    (DEBUG_FLOAT_ARRAY at 50 Hz read them one by one for ~4 µs)."""
    if isinstance(internals, InternalValues) and internals._keys == keys:
        return internals._values
    return [internals[k] for k in keys]


def control_output(out: np.ndarray, internal_keys: tuple[str, ...]) -> ControlOutput:
    """A compiled step's output array as the contract's `ControlOutput` (its arrays are views of it)."""
    return ControlOutput(float(out[0]), out[1:4], out[4:7], InternalValues(internal_keys, out[INTERNALS:]))


class GainValues:
    """A gains model's values in a fixed order, as compiled code takes them; packed again only when the model is
    swapped (a PARAM_SET replaces the frozen model)."""

    def __init__(self, names: tuple[str, ...]) -> None:
        self.names = names
        self._packed_from: object = None
        self._values = np.zeros(len(names))

    def of(self, gains: object) -> np.ndarray:
        if gains is not self._packed_from:
            self._values = np.array([float(getattr(gains, name)) for name in self.names])
            self._packed_from = gains
        return self._values
