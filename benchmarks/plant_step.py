"""µs per plant step (set inputs + doStep + get outputs), 4 ms communication step, 1 ms RK4 steps.

Through `plant_fmu.Plant` (pre-resolved value references, raw ctypes calls) without and with the
inspection quad's rotor aerodynamics (in a crosswind, so every term works), and, for comparison,
through fmpy's high-level FMU2Slave methods with lists.
"""

from __future__ import annotations

import tempfile
import time

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
from run_timing import benchmark_parser

from hil.scenario.vehicles import INSPECTION_QUAD_AERO
from plant_fmu import Plant, ensure_fmu

STEPS, QUICK_STEPS = 20_000, 250
DT = 0.004


def bench_plant(parameters: dict[str, float], steps: int) -> float:
    with Plant({"init_pos_d": -1e6, **parameters}) as plant:
        u = np.zeros(len(plant.input_names))
        u[[plant.input_index[f"motor_cmd_{i}"] for i in range(1, 5)]] = 0.61
        u[[plant.input_index[f"motor_health_{i}"] for i in range(1, 5)]] = 1.0
        u[plant.input_index["wind_e"]] = 4.0
        start = time.perf_counter()
        for _ in range(steps):
            plant.set_inputs(u)
            plant.step(DT)
        return (time.perf_counter() - start) / steps * 1e6


def bench_fmpy_high_level(steps: int) -> float:
    path = ensure_fmu()
    description = read_model_description(str(path))
    fmu = FMU2Slave(guid=description.guid, unzipDirectory=extract(str(path), tempfile.mkdtemp()),
                    modelIdentifier="Quadrotor")
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    vr = {v.name: v.valueReference for v in description.modelVariables}
    with Plant() as plant:  # the same variables as the plant's hot path, by the default mapping's names
        in_vr = [vr[n] for n in plant.input_names]
        out_vr = [vr[n] for n in plant.output_names]
    values = [0.61] * 4 + [1.0] * 4 + [0.0] * (len(in_vr) - 8)
    t = 0.0
    start = time.perf_counter()
    for _ in range(steps):
        fmu.setReal(in_vr, values)
        fmu.doStep(currentCommunicationPoint=t, communicationStepSize=DT)
        fmu.getReal(out_vr)
        t += DT
    elapsed = (time.perf_counter() - start) / steps * 1e6
    fmu.terminate()
    fmu.freeInstance()
    return elapsed


def main() -> None:
    args = benchmark_parser(__doc__).parse_args()
    steps = QUICK_STEPS if args.quick else STEPS
    ensure_fmu()
    plant_us = min(bench_plant({}, steps) for _ in range(3))
    aero_us = min(bench_plant(INSPECTION_QUAD_AERO, steps) for _ in range(3))
    fmpy_us = bench_fmpy_high_level(steps)
    print(f"plant step, {DT * 1e3:.0f} ms communication step, 1 ms RK4, {steps} steps (best of 3)")
    print(f"  plant_fmu.Plant, no rotor aerodynamics   : {plant_us:6.2f} us/step")
    print(f"  plant_fmu.Plant, inspection quad's aero  : {aero_us:6.2f} us/step ({aero_us / plant_us:.2f}x)")
    print(f"  fmpy FMU2Slave (lists), no aerodynamics  : {fmpy_us:6.2f} us/step")


if __name__ == "__main__":
    main()
