"""`Plant`: a thin typed wrapper over fmpy's FMU2Slave for the quadrotor FMU.

The hot path (set inputs, doStep, get outputs) calls the FMU's C functions with
pre-built ctypes arrays of value references, so a bench step costs microseconds.
"""

from __future__ import annotations

import ctypes
import re
import shutil
import tempfile
from collections.abc import Mapping
from pathlib import Path
from types import TracebackType
from typing import Any, Self

import numpy as np
from fmpy import calloc, extract, free, read_model_description
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)

from plant_fmu.build import ensure_fmu
from plant_fmu.state import REAL_OUTPUT_NAMES, PlantState
from plant_fmu.variables import INPUT_NAMES, PARAMETER_NAMES, VR, span

_MOTORS, _HEALTH = span(INPUT_NAMES, "motor_cmd_1", 4), span(INPUT_NAMES, "motor_health_1", 4)
_WIND, _FORCE = span(INPUT_NAMES, "wind_n", 3), span(INPUT_NAMES, "f_dist_n", 3)
_TORQUE, _PAYLOAD = span(INPUT_NAMES, "tau_dist_x", 3), INPUT_NAMES.index("payload_mass")
_FMI_OK_OR_WARNING = 1


_VARIABLE_NUMBER = re.compile(r"variable (\d+)")
_NAME_OF_VR = {vr: name for name, vr in VR.items()}


def _named(fmu_message: str) -> str:
    """The FMU names variables by value reference; a user knows them by name."""
    return _VARIABLE_NUMBER.sub(lambda m: f"variable {_NAME_OF_VR.get(int(m.group(1)), m.group(1))}", fmu_message)


class PlantError(RuntimeError):
    """The FMU refused a call or its state diverged; the message holds the FMU's log."""


def _vr_array(names: tuple[str, ...]) -> ctypes.Array:
    return (ctypes.c_uint * len(names))(*(VR[n] for n in names))


class Plant:
    """One instance of the quadrotor FMU, ready to step.

    Inputs and outputs are numpy arrays in the order of `INPUT_NAMES` and
    `REAL_OUTPUT_NAMES`; `input_index` / `output_index` map names to positions.
    """

    INPUT_NAMES = INPUT_NAMES
    OUTPUT_NAMES = REAL_OUTPUT_NAMES

    def __init__(
        self,
        parameters: Mapping[str, float] | None = None,
        fmu_path: Path | None = None,
        instance_name: str = "plant",
        initial_inputs: np.ndarray | None = None,
    ) -> None:
        self.fmu_path = ensure_fmu(fmu_path)
        description = read_model_description(str(self.fmu_path))
        self._closed = True  # until the instance exists: close() then only removes the unpacked folder
        self._unzip_dir = tempfile.mkdtemp(prefix="quadrotor-")
        try:
            self._open(description, instance_name, parameters, initial_inputs)
        except BaseException:  # Ctrl-C or SIGTERM while unpacking or initialising leaves no folder behind
            self._discard()
            raise

    def _open(self, description: Any, instance_name: str, parameters: Mapping[str, float] | None,
              initial_inputs: np.ndarray | None) -> None:
        """Unpack, instantiate and initialise the FMU (the part of construction that may be cut short)."""
        extract(str(self.fmu_path), self._unzip_dir)
        self._log: list[str] = []
        self._callbacks = self._make_callbacks()
        self._fmu = FMU2Slave(
            guid=description.guid,
            unzipDirectory=self._unzip_dir,
            modelIdentifier=description.coSimulation.modelIdentifier,
            instanceName=instance_name,
        )
        self._fmu.instantiate(callbacks=self._callbacks)
        self._closed = False
        self._component = self._fmu.component
        dll = self._fmu.dll
        self._set_real, self._get_real = dll.fmi2SetReal, dll.fmi2GetReal
        self._get_boolean, self._do_step = dll.fmi2GetBoolean, dll.fmi2DoStep
        self._in_vr = _vr_array(INPUT_NAMES)
        self._in_values = (ctypes.c_double * len(INPUT_NAMES))()
        self._out_vr = _vr_array(REAL_OUTPUT_NAMES)
        self._out_values = (ctypes.c_double * len(REAL_OUTPUT_NAMES))()
        self._in_view = np.ctypeslib.as_array(self._in_values)
        self._out_view = np.ctypeslib.as_array(self._out_values)
        self._ground_vr = (ctypes.c_uint * 1)(VR["on_ground"])
        self._ground_value = (ctypes.c_int * 1)()
        self.input_index = {n: i for i, n in enumerate(INPUT_NAMES)}
        self.output_index = {n: i for i, n in enumerate(REAL_OUTPUT_NAMES)}
        self.t = 0.0
        self._initialize(parameters or {}, initial_inputs)

    def _make_callbacks(self) -> fmi2CallbackFunctions:
        def logger(env, name, status, category, message) -> None:
            self._log.append(message.decode(errors="replace") if message else "")

        callbacks = fmi2CallbackFunctions()
        callbacks.logger = fmi2CallbackLoggerTYPE(logger)
        callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        return callbacks

    def _check(self, status: int, what: str) -> None:
        if status > _FMI_OK_OR_WARNING:
            detail = self._log[-1] if self._log else "no message from the FMU"
            raise PlantError(f"{what} failed at t = {self.t:.6f} s: {_named(detail)}")

    def _initialize(self, parameters: Mapping[str, float], initial_inputs: np.ndarray | None) -> None:
        unknown = sorted(set(parameters) - set(PARAMETER_NAMES) - set(INPUT_NAMES))
        if unknown:
            raise PlantError(f"unknown plant parameter(s): {', '.join(unknown)}")
        self._fmu.setupExperiment(startTime=0.0)
        names = tuple(parameters)
        if names:
            values = (ctypes.c_double * len(names))(*(float(parameters[n]) for n in names))
            self._check(self._set_real(self._component, _vr_array(names), len(names), values), "setting parameters")
        if initial_inputs is not None:  # before initialization: rotor lag states start in trim
            self.set_inputs(initial_inputs)
        self._check(self._fmu.fmi2EnterInitializationMode(self._component), "entering initialization")
        self._check(self._fmu.fmi2ExitInitializationMode(self._component), "initialization")
        self.t = 0.0
        self._refresh()

    def _refresh(self) -> None:
        self._check(
            self._get_real(self._component, self._out_vr, len(REAL_OUTPUT_NAMES), self._out_values),
            "reading outputs",
        )

    def set_inputs(self, values: np.ndarray) -> None:
        """Set every input at once, in `INPUT_NAMES` order."""
        self._in_view[:] = values
        self._check(self._set_real(self._component, self._in_vr, len(INPUT_NAMES), self._in_values), "setting inputs")

    def set_input_groups(self, motor_cmds: tuple[float, ...], motor_health: tuple[float, ...],
                         wind_ned: np.ndarray, force_ned: np.ndarray, torque_frd: np.ndarray,
                         payload_kg: float) -> None:
        """Every input at once, by group: rotor commands 0..1 and health multipliers (PX4 quad X order),
        wind and disturbance force in NED (m/s, N), disturbance torque in FRD (N·m), payload (kg)."""
        v = self._in_view
        v[_MOTORS], v[_HEALTH], v[_WIND] = motor_cmds, motor_health, wind_ned
        v[_FORCE], v[_TORQUE], v[_PAYLOAD] = force_ned, torque_frd, payload_kg
        self._check(self._set_real(self._component, self._in_vr, len(INPUT_NAMES), self._in_values), "setting inputs")

    def state(self) -> PlantState:
        """The outputs as a typed state (a copy: it stays valid after the next step)."""
        return PlantState.from_outputs(self._out_view.copy(), self.on_ground)

    def set_input(self, name: str, value: float) -> None:
        vr = (ctypes.c_uint * 1)(VR[name])
        self._check(self._set_real(self._component, vr, 1, (ctypes.c_double * 1)(value)), f"setting {name}")

    def step(self, dt_s: float) -> np.ndarray:
        """Advance by `dt_s` seconds and return the outputs (a view, valid until the next step)."""
        self._check(self._do_step(self._component, self.t, dt_s, 1), "doStep")
        self.t += dt_s
        self._refresh()
        return self._out_view

    def outputs(self) -> np.ndarray:
        """The current outputs in `OUTPUT_NAMES` order (a view, valid until the next step)."""
        return self._out_view

    def output(self, name: str) -> float:
        return float(self._out_view[self.output_index[name]])

    @property
    def on_ground(self) -> bool:
        self._check(self._get_boolean(self._component, self._ground_vr, 1, self._ground_value), "reading on_ground")
        return bool(self._ground_value[0])

    def reset(self, parameters: Mapping[str, float] | None = None, initial_inputs: np.ndarray | None = None) -> None:
        """Back to t = 0 with default inputs, then the given parameters and initial inputs."""
        self._check(self._fmu.fmi2Reset(self._component), "reset")
        self._initialize(parameters or {}, initial_inputs)

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            self._fmu.terminate()
            self._fmu.freeInstance()
        shutil.rmtree(self._unzip_dir, ignore_errors=True)

    def _discard(self) -> None:
        """A half-built plant: free the instance if there is one, and remove the unpacked FMU."""
        if not self._closed:
            self._closed = True
            self._fmu.freeInstance()
        shutil.rmtree(self._unzip_dir, ignore_errors=True)

    def __enter__(self) -> Self:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    def __del__(self) -> None:
        if not getattr(self, "_closed", True):
            self.close()
