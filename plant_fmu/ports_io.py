"""The bench's values to the FMU's inputs, and the FMU's outputs to a `PlantState`, through a resolved
mapping: unit factors and frame rotations where the FMU differs from the bench, plain slices where it does
not (then the values pass bit for bit)."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from plant_fmu.contract import INPUT_PORTS, OUTPUT_PORTS, PORTS
from plant_fmu.frames import (
    BODY_TO_FRD,
    EARTH_TO_NED,
    dcm_to_euler_zyx,
    dcm_to_quat,
    euler_zyx_to_dcm,
    quat_to_dcm,
    to_bench_attitude,
)
from plant_fmu.resolve import ResolvedMapping, ResolvedPort
from plant_fmu.state import BatteryState, PlantState

GROUNDED_TOLERANCE_M = 0.01  # derived on_ground: this close to the ground found at start-up
_NAN3 = np.full(3, math.nan)
# the outputs that, all mapped without conversion, let the state be slices of the output vector
_PLAIN = ("position", "velocity", "acceleration", "attitude_quaternion", "attitude_euler", "body_rates",
          "specific_force", "rotor_thrust", "rotor_speed", "thrust_total", "rotor_torque", "total_mass")


def _matrix(resolved: ResolvedMapping, frame: str) -> np.ndarray | None:
    frames = resolved.mapping.spec.frames
    return {"earth": EARTH_TO_NED[frames.earth], "body": BODY_TO_FRD[frames.body]}.get(frame)


def _layout(ports: Sequence[ResolvedPort]) -> tuple[list[str], list[int], dict[str, slice]]:
    names: list[str] = []
    vrs: list[int] = []
    slices: dict[str, slice] = {}
    for port in ports:
        slices[port.port.name] = slice(len(names), len(names) + len(port.names))
        names += port.names
        vrs += port.vrs
    return names, vrs, slices


# the inputs the bench sets every step, in `Plant.set_input_groups`'s order
GROUPS = ("rotor_command", "rotor_health", "wind", "force", "torque", "payload_mass")


class InputWriter:
    """Writes the bench's inputs into the vector of the FMU's mapped inputs, in their order."""

    def __init__(self, resolved: ResolvedMapping) -> None:
        ports = [resolved.inputs[p.name] for p in INPUT_PORTS if p.name in resolved.inputs]
        self.names, self.vrs, self.slices = _layout(ports)
        self._conversion = {p.port.name: (p.factor, _matrix(resolved, p.port.frame)) for p in ports}
        low, high = resolved.mapping.spec.rotors.command_range
        self._command_scale = None if (low, high) == (0.0, 1.0) else (low, high - low)
        self.missing = tuple(p.name for p in INPUT_PORTS if p.name not in resolved.inputs)
        plain = self._command_scale is None and all(f == 1.0 and m is None for f, m in self._conversion.values())
        self.plain_groups = tuple(self.slices[p] for p in GROUPS) if plain and set(GROUPS) <= set(self.slices) else None

    def write(self, view: np.ndarray, port: str, value: np.ndarray | Sequence[float] | float) -> None:
        """One port's value (SI, NED, FRD) into `view`, converted to the FMU's unit and frame."""
        factor, matrix = self._conversion[port]
        if port == "rotor_command" and self._command_scale is not None:
            value = self._command_scale[0] + self._command_scale[1] * np.asarray(value, dtype=float)
        elif factor != 1.0 or matrix is not None:
            value = np.asarray(value, dtype=float) / factor
            value = value if matrix is None else matrix @ value  # each frame change is its own inverse
        view[self.slices[port]] = value


class StateReader:
    """Builds the typed state from the vector of the FMU's mapped real outputs."""

    def __init__(self, resolved: ResolvedMapping) -> None:
        self.gravity = resolved.mapping.spec.gravity_m_s2
        self.rotor_count = resolved.mapping.rotor_count
        real = [resolved.outputs[p.name] for p in OUTPUT_PORTS if p.name in resolved.outputs
                and p.quantity != "boolean"]
        self.names, self.vrs, self.slices = _layout(real)
        self.boolean_vrs = [resolved.outputs["on_ground"].vrs[0]] if "on_ground" in resolved.outputs else []
        self._conversion = {p.port.name: (p.factor, _matrix(resolved, p.port.frame)) for p in real}
        self._attitude = _AttitudeReader(resolved)
        self.ground_d = math.inf  # set by `find_ground` when the plant starts at rest
        plain = self._attitude.plain and bool(self.boolean_vrs) and all(
            name in self.slices and self._conversion[name] == (1.0, None) for name in _PLAIN)
        self._plain_slices = tuple(self.slices[n] if PORTS[n].size != 1 else self.slices[n].start
                                   for n in _PLAIN) if plain else None
        battery = ("battery_voltage", "battery_current", "battery_consumed", "battery_remaining")
        self._has_battery = all(name in self.slices for name in battery)
        self._battery_at = tuple((self.slices[n].start, self._conversion[n][0]) for n in battery
                                 ) if self._has_battery else ()
        self._cells = self.slices.get("cell_voltages", slice(0, 0))
        self._cells_plain = "cell_voltages" not in self.slices or self._conversion["cell_voltages"] == (1.0, None)

    def _get(self, o: np.ndarray, port: str, default: np.ndarray | None = None) -> np.ndarray:
        if port not in self.slices:
            return default if default is not None else np.full(self.rotor_count, math.nan)
        factor, matrix = self._conversion[port]
        value = o[self.slices[port]]
        if factor != 1.0:
            value = value * factor
        return value if matrix is None else matrix @ value

    def _scalar(self, o: np.ndarray, port: str) -> float:
        return float(self._get(o, port, _NAN3)[0]) if port in self.slices else math.nan

    def state(self, o: np.ndarray, on_ground: bool | None) -> PlantState:
        """From `o` (a copy of the outputs, which the state keeps); `on_ground` as the FMU says, if it does."""
        if self._plain_slices is not None:
            pos, vel, acc, q, rpy, rates, force, thrusts, speeds, total, torque, mass = self._plain_slices
            return PlantState(o[pos], o[vel], o[acc], o[q], o[rpy], o[rates], o[force], o[thrusts], o[speeds],
                              o[torque], float(o[total]), float(o[mass]), bool(on_ground),
                              self._battery(o) if self._has_battery else None)
        s = self.slices
        pos, force = self._get(o, "position"), self._get(o, "specific_force")
        q, rpy, r = self._attitude.read(o, self.slices)
        acc = self._get(o, "acceleration") if "acceleration" in s else r @ force + np.array((0.0, 0.0, self.gravity))
        thrusts = self._get(o, "rotor_thrust")
        total = self._scalar(o, "thrust_total") if "thrust_total" in s else float(np.sum(thrusts))
        grounded = on_ground if on_ground is not None else bool(pos[2] >= self.ground_d - GROUNDED_TOLERANCE_M)
        return PlantState(pos, self._get(o, "velocity"), acc, q, rpy, self._get(o, "body_rates"), force, thrusts,
                          self._get(o, "rotor_speed"), self._get(o, "rotor_torque", np.full(3, math.nan)), total,
                          self._scalar(o, "total_mass"), grounded, self._battery(o) if self._has_battery else None)

    def live(self, o: np.ndarray) -> LiveOutputs | None:
        """Views of the motion in `o` (the plant's output buffer, rewritten in place by each step), when the mapping
        needs no conversion; None otherwise."""
        if self._plain_slices is None:
            return None
        pos, vel, _, q, _, rates, force = self._plain_slices[:7]
        return LiveOutputs(o[pos], o[vel], o[q], o[rates], o[force], lambda: self._battery(o) if self._has_battery
                           else None)

    def _battery(self, o: np.ndarray) -> BatteryState:
        (v, fv), (i, fi), (c, fc), (r, fr) = self._battery_at
        cells = o[self._cells] if self._cells_plain else self._get(o, "cell_voltages")
        return BatteryState(float(o[v]) * fv, float(o[i]) * fi, float(o[c]) * fc, float(o[r]) * fr, cells)

    def find_ground(self, state: PlantState) -> None:
        """A plant that starts resting (the accelerometer reads g, nothing moves) is on its ground."""
        if abs(float(np.linalg.norm(state.specific_force_frd)) - self.gravity) < 0.05 * self.gravity and float(
                np.linalg.norm(state.vel_ned)) < 0.01:
            self.ground_d = float(state.pos_ned[2])


class LiveOutputs:
    """The plant's motion as views of its output buffer: each step's values in place, nothing copied (`live`)."""

    __slots__ = ("_battery", "pos_ned", "q_wxyz", "rates_frd", "specific_force_frd", "vel_ned")

    def __init__(self, pos_ned: np.ndarray, vel_ned: np.ndarray, q_wxyz: np.ndarray, rates_frd: np.ndarray,
                 specific_force_frd: np.ndarray, battery: Callable[[], BatteryState | None]) -> None:
        self.pos_ned, self.vel_ned, self.q_wxyz, self.rates_frd = pos_ned, vel_ned, q_wxyz, rates_frd
        self.specific_force_frd, self._battery = specific_force_frd, battery

    @property
    def battery(self) -> BatteryState | None:
        return self._battery()


class _AttitudeReader:
    """The attitude as quaternion and Euler angles in NED/FRD, from whichever of the two the FMU gives."""

    def __init__(self, resolved: ResolvedMapping) -> None:
        frames, outputs = resolved.mapping.spec.frames, resolved.outputs
        self.earth, self.body = frames.earth, frames.body
        self.quaternion = outputs.get("attitude_quaternion")
        self.euler = outputs.get("attitude_euler")
        q_spec = self.quaternion.spec if self.quaternion else None
        self.plain = (self.quaternion is not None and self.euler is not None and self.euler.factor == 1.0
                      and (frames.earth, frames.body) == ("NED", "FRD") and q_spec is not None
                      and (q_spec.order, q_spec.rotates) == ("wxyz", "body_to_earth"))

    def read(self, o: np.ndarray, slices: dict[str, slice]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(q_wxyz, rpy, R) in the bench's frames."""
        if self.quaternion is not None and self.quaternion.spec is not None:
            q = o[slices["attitude_quaternion"]]
            q = q if self.quaternion.spec.order == "wxyz" else q[[3, 0, 1, 2]]
            r_fmu = quat_to_dcm(q)
            r_fmu = r_fmu if self.quaternion.spec.rotates == "body_to_earth" else r_fmu.T
        else:
            assert self.euler is not None  # the mapping has one of the two
            r_fmu = euler_zyx_to_dcm(*(o[slices["attitude_euler"]] * self.euler.factor))
        r = to_bench_attitude(r_fmu, self.earth, self.body)
        if self.plain:
            return o[slices["attitude_quaternion"]], o[slices["attitude_euler"]], r
        return dcm_to_quat(r), dcm_to_euler_zyx(r), r
