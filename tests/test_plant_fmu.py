"""The FMU as an artefact: valid FMI 2.0, loadable by a plain C host, rebuilt only on change, leak-free."""

from __future__ import annotations

import resource
import shutil
import subprocess
import tempfile
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi2 import FMU2Slave
from fmpy.validation import validate_fmu

from plant_fmu import Plant, PlantError, build
from plant_fmu.build import FmuBuildError, build_fmu, fmi_header_dir
from plant_fmu.variables import INPUT_NAMES, OUTPUT_NAMES, PARAMETER_NAMES, VR

HERE = Path(__file__).parent


def test_fmpy_validation_reports_no_problem(fmu_path):
    assert validate_fmu(str(fmu_path)) == []


def test_simulate_fmu_runs_with_fmpys_own_master(fmu_path):
    result = simulate_fmu(str(fmu_path), stop_time=2.0, output_interval=0.01,
                          start_values={"init_pos_d": -30.0}, output=["pos_d", "vel_d"])
    # motors off from 30 m with linear drag 0.35 N.s/m: v(2 s) = g m/c (1 - exp(-c t / m))
    c, m, g = 0.35, 1.0, 9.80665
    import math
    assert result["vel_d"][-1] == pytest.approx(g * m / c * (1 - math.exp(-c * 2.0 / m)), rel=1e-6)


def test_interface_names_are_the_public_contract(fmu_path):
    description = read_model_description(str(fmu_path))
    names = {v.name: v.causality for v in description.modelVariables}
    for i in range(1, 5):
        assert names[f"motor_cmd_{i}"] == "input" and names[f"motor_health_{i}"] == "input"
    for n in ("wind_n", "f_dist_d", "tau_dist_z", "payload_mass"):
        assert names[n] == "input"
    for n in ("mass", "Ixx", "thrust_curve_k", "motor_tau", "yaw_moment_coeff", "ground_height", "integration_step"):
        assert names[n] == "parameter"
    for n in ("pos_n", "acc_d", "q_w", "yaw", "rate_z", "specific_force_z", "thrust_total", "torque_y",
              "total_mass", "on_ground"):
        assert names[n] == "output"
    assert len(names) == len(INPUT_NAMES) + len(OUTPUT_NAMES) + len(PARAMETER_NAMES)


def test_fmu_ships_sources_with_a_build_description(fmu_path):
    with zipfile.ZipFile(fmu_path) as z:
        listing = set(z.namelist())
    assert {"modelDescription.xml", "sources/quadrotor.c", "sources/quadrotor_vars.h",
            "sources/buildDescription.xml", "binaries/linux64/Quadrotor.so"} <= listing


def c_host(fmu_path: Path, tmp_path: Path, steps: int, output: str, parameters: dict[str, float],
           inputs: dict[str, float] | None = None) -> float:
    """Run the FMU in the plain C host (a second FMI importer) and return one output at the end."""
    if shutil.which("cc") is None:
        pytest.fail("a C compiler is required to build the FMU, so it must be present here")
    host = tmp_path / "host"
    if not host.exists():
        subprocess.run(["cc", "-std=c99", "-I", str(fmi_header_dir()), str(HERE / "data" / "c_host.c"),
                        "-o", str(host), "-ldl"], check=True)
    unzipped = extract(str(fmu_path), str(tmp_path / "fmu"))
    guid = read_model_description(str(fmu_path)).guid
    result = subprocess.run([str(host), str(Path(unzipped) / "binaries/linux64/Quadrotor.so"), guid, str(steps),
                             str(VR[output]), *(f"{VR[n]}={v!r}" for n, v in parameters.items()), "--",
                             *(f"{VR[n]}={v!r}" for n, v in (inputs or {}).items())],
                            capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    return float(result.stdout)


def test_a_plain_c_host_loads_and_steps_the_binary(fmu_path, tmp_path):
    assert c_host(fmu_path, tmp_path, 250, "pos_d", {}) == 0.0  # resting on the ground with motors off


def test_the_c_host_and_fmpy_give_the_same_flight_with_rotor_aerodynamics(fmu_path, tmp_path):
    """Climbing through a crosswind with the inspection quad's aerodynamics, 2 s: the same numbers from both
    importers (both step the same binary; the check is that nothing depends on the host)."""
    from hil.scenario.vehicles import INSPECTION_QUAD_AERO

    inputs = {**{f"motor_cmd_{i}": 0.65 + 0.01 * i for i in range(1, 5)},
              **{f"motor_health_{i}": 1.0 for i in range(1, 5)}, "wind_e": 4.0, "wind_d": -1.0}
    with Plant(INSPECTION_QUAD_AERO) as plant:
        u = np.zeros(len(plant.input_names))
        for name, value in inputs.items():
            u[plant.input_index[name]] = value
        plant.set_inputs(u)
        for _ in range(500):
            out = plant.step(0.004)
        expected = {name: float(out[plant.output_index[name]]) for name in ("pos_e", "pos_d", "roll", "yaw")}
    for name, value in expected.items():
        assert c_host(fmu_path, tmp_path, 500, name, INSPECTION_QUAD_AERO, inputs) == value


def test_rebuilds_only_when_sources_change(tmp_path, monkeypatch):
    out = tmp_path / "Quadrotor.fmu"
    assert build_fmu(out) == (out, True)
    assert build_fmu(out) == (out, False)
    monkeypatch.setattr(build, "source_hash", lambda: "a-different-source")
    assert build_fmu(out) == (out, True)


def test_missing_c_compiler_is_a_clear_error(tmp_path, monkeypatch):
    monkeypatch.setenv("PATH", str(tmp_path))
    monkeypatch.delenv("CC", raising=False)
    with pytest.raises(FmuBuildError, match="no C compiler found"):
        build_fmu(tmp_path / "Quadrotor.fmu", force=True)


def _rss_mb() -> float:
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


@pytest.mark.slow
def test_thousand_instantiate_step_free_cycles_do_not_leak(fmu_path, tmp_path):
    description = read_model_description(str(fmu_path))
    unzipped = extract(str(fmu_path), str(tmp_path / "fmu"))

    def cycle() -> None:
        fmu = FMU2Slave(guid=description.guid, unzipDirectory=unzipped,
                        modelIdentifier=description.coSimulation.modelIdentifier, instanceName="leak")
        fmu.instantiate()
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        for i in range(10):
            fmu.doStep(currentCommunicationPoint=i * 0.004, communicationStepSize=0.004)
        fmu.terminate()
        fmu.freeInstance()

    for _ in range(100):
        cycle()
    before = _rss_mb()
    for _ in range(1000):
        cycle()
    assert _rss_mb() - before < 4.0


def test_a_plant_that_fails_while_initialising_leaves_no_unpacked_fmu(fmu_path, tmp_path, monkeypatch):
    """Construction cut short after the FMU is unpacked and instantiated (here by a bad parameter; in a run,
    by Ctrl-C or SIGTERM) removes the folder and frees the instance."""
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    with pytest.raises(PlantError, match="no_such_parameter"):
        Plant({"no_such_parameter": 1.0}, fmu_path=fmu_path)
    assert not list(tmp_path.glob("plant-fmu-*"))
    with Plant(fmu_path=fmu_path):
        assert len(list(tmp_path.glob("plant-fmu-*"))) == 1  # the same place, so the check above can see it
    assert not list(tmp_path.glob("plant-fmu-*"))
