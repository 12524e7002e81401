"""One FMU instance through fmpy's raw ctypes functions, FMI 2.0 or 3.0 co-simulation alike: the calls the
plant makes, each returning the FMI status, so that a step costs microseconds."""

from __future__ import annotations

import ctypes
from collections.abc import Callable
from functools import partial
from typing import Any

from fmpy import calloc, free
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)
from fmpy.fmi3 import FMU3Slave

Status = int
_FMI2_SETTERS: dict[str, tuple[str, Any]] = {
    "Real": ("fmi2SetReal", ctypes.c_double), "Integer": ("fmi2SetInteger", ctypes.c_int),
    "Boolean": ("fmi2SetBoolean", ctypes.c_int)}
_FMI3_SETTERS: dict[str, tuple[str, Any]] = {
    "Float64": ("fmi3SetFloat64", ctypes.c_double), "Int32": ("fmi3SetInt32", ctypes.c_int32),
    "Int64": ("fmi3SetInt64", ctypes.c_int64), "Boolean": ("fmi3SetBoolean", ctypes.c_bool)}


def vr_array(vrs: tuple[int, ...] | list[int]) -> ctypes.Array:
    return (ctypes.c_uint * len(vrs))(*vrs)


class FmuInstance:
    """Instantiated, not yet initialised; `log` collects the FMU's messages."""

    def __init__(self, fmi_version: str, unzip_dir: str, model_identifier: str, token: str, name: str) -> None:
        self.fmi3 = fmi_version.startswith("3")
        self.log: list[str] = []
        slave = FMU3Slave if self.fmi3 else FMU2Slave
        self.slave: Any = slave(guid=token, unzipDirectory=unzip_dir, modelIdentifier=model_identifier,
                                instanceName=name)
        if self.fmi3:
            self.slave.instantiate(logMessage=self._log3)
        else:
            self._callbacks = self._fmi2_callbacks()
            self.slave.instantiate(callbacks=self._callbacks)
        self.component = self.slave.component
        self.dll = self.slave.dll
        self._step_refs = tuple(ctypes.byref(c()) for c in (ctypes.c_bool,) * 3 + (ctypes.c_double,))

    def _fmi2_callbacks(self) -> fmi2CallbackFunctions:
        def logger(env, name, status, category, message) -> None:
            self.log.append(message.decode(errors="replace") if message else "")

        callbacks = fmi2CallbackFunctions()
        callbacks.logger = fmi2CallbackLoggerTYPE(logger)
        callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        return callbacks

    def _log3(self, env, status, category, message) -> None:
        self.log.append(message.decode(errors="replace") if message else "")

    def reals_setter(self, vrs: ctypes.Array, values: ctypes.Array) -> Callable[[], Status]:
        """A call that writes `values` (a ctypes double array kept by the caller) to `vrs`."""
        if self.fmi3:
            return partial(self.dll.fmi3SetFloat64, self.component, vrs, len(vrs), values, len(values))
        return partial(self.dll.fmi2SetReal, self.component, vrs, len(vrs), values)

    def reals_getter(self, vrs: ctypes.Array, values: ctypes.Array) -> Callable[[], Status]:
        if self.fmi3:
            return partial(self.dll.fmi3GetFloat64, self.component, vrs, len(vrs), values, len(values))
        return partial(self.dll.fmi2GetReal, self.component, vrs, len(vrs), values)

    def booleans_getter(self, vrs: ctypes.Array) -> tuple[Callable[[], Status], ctypes.Array]:
        out: ctypes.Array = (ctypes.c_bool * len(vrs))() if self.fmi3 else (ctypes.c_int * len(vrs))()
        if self.fmi3:
            return partial(self.dll.fmi3GetBoolean, self.component, vrs, len(vrs), out, len(out)), out
        return partial(self.dll.fmi2GetBoolean, self.component, vrs, len(vrs), out), out

    def stepper(self) -> tuple[Callable[..., Status], tuple[Any, ...]]:
        """doStep as a call and the arguments after (t, h): `call(t, h, *tail)`."""
        if self.fmi3:
            return partial(self.dll.fmi3DoStep, self.component), (True, *self._step_refs)
        return partial(self.dll.fmi2DoStep, self.component), (1,)

    def set_typed(self, fmi_type: str, vr: int, value: float) -> Status:
        """One parameter or start value, of its FMI type (not on the hot path)."""
        name, ctype = (_FMI3_SETTERS if self.fmi3 else _FMI2_SETTERS)[fmi_type]
        vrs, values = vr_array([vr]), (ctype * 1)(ctype(round(value)) if ctype is not ctypes.c_double else value)
        if self.fmi3:
            return getattr(self.dll, name)(self.component, vrs, 1, values, 1)
        return getattr(self.dll, name)(self.component, vrs, 1, values)

    def setup_and_enter_initialization(self) -> Status:
        if self.fmi3:
            return self.dll.fmi3EnterInitializationMode(self.component, False, 0.0, 0.0, False, 0.0)
        self.slave.setupExperiment(startTime=0.0)
        return self.dll.fmi2EnterInitializationMode(self.component)

    def exit_initialization(self) -> Status:
        return (self.dll.fmi3ExitInitializationMode if self.fmi3 else self.dll.fmi2ExitInitializationMode)(
            self.component)

    def reset(self) -> Status:
        return (self.dll.fmi3Reset if self.fmi3 else self.dll.fmi2Reset)(self.component)

    def terminate(self) -> None:
        self.slave.terminate()

    def free(self) -> None:
        """The instance freed, then the library unloaded, as fmpy's freeInstance does. An FMU exported by pythonfmu
        0.7.0 (FMI 2; pythonfmu3 0.3.4's source for FMI 3 is the same) holds its interpreter state in a static
        shared pointer that C++'s exit handlers free and its library destructor then releases again, after: a write
        into freed memory at every exit of the process, which corrupted glibc's free lists in some runs ("corrupted
        double-linked list", exit -6, once in a clean CI run). Its own exported `finalizePythonInterpreter` releases
        that state while it is live, so both exit paths find it empty (tests/test_pythonfmu_exit.py, valgrind)."""
        release_interpreter_state = getattr(self.dll, "finalizePythonInterpreter", None)
        (self.slave.fmi3FreeInstance if self.fmi3 else self.slave.fmi2FreeInstance)(self.component)
        if release_interpreter_state is not None:
            release_interpreter_state.restype = None
            release_interpreter_state()
        self.slave.freeLibrary()
