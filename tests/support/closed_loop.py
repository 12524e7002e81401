"""Fly a controller on the plant FMU in-process with the true state (tests may import both)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from firmware_interface.emulator.config import EmulatorConfig
from firmware_interface.emulator.control import Controller, Setpoint, VehicleState
from firmware_interface.emulator.control.registry import make_controller
from firmware_interface.emulator.estimator import Estimator
from firmware_interface.emulator.mixer import Mixer
from hil.scenario.environment import Environment
from hil.scenario.reference import Helix, Hover, Trajectory
from hil.scenario.schema import Scenario
from hil.sensors import Home, SensorsConfig, SensorSuite, TrueState
from plant_fmu import Plant

PAPER_PLANT = {"mass": 1.0, "Ixx": 0.121, "Iyy": 0.121, "Izz": 0.151, "arm_length": 0.5, "thrust_max": 40.0,
               "thrust_curve_k": 0.0, "motor_tau": 0.0, "yaw_moment_coeff": 0.05, "rotor_reversible": 1.0,
               "drag_coeff_x": 0.0, "drag_coeff_y": 0.0, "drag_coeff_z": 0.0}


def as_setpoints(trajectory: Trajectory) -> Callable[[float], Setpoint]:
    def at(t: float) -> Setpoint:
        r = trajectory.sample(t)
        return Setpoint(r.pos_ned, r.vel_ned, r.acc_ned, r.yaw)
    return at


def helix(altitude: float = 10.0) -> Callable[[float], Setpoint]:
    """The paper's helix with a 2 s smooth start, circle centred so that it starts at (1, 0, -altitude)."""
    return as_setpoints(Helix(center_ned=(0.0, 0.0, -altitude)))


def hover(point: tuple[float, float, float], yaw: float = 0.0) -> Callable[[float], Setpoint]:
    return as_setpoints(Hover(point, yaw))


def scenario_inputs(scenario: Scenario, dt: float) -> Callable[[float, Plant, np.ndarray], None]:
    """The scenario's disturbance force and torque and payload steps as `fly` inputs (mission time = t): the
    same expressions the bench evaluates."""
    environment = Environment(scenario, dt, np.random.default_rng(scenario.seed), 4)

    def inputs(t: float, plant: Plant, u: np.ndarray) -> None:
        sample, i = environment.sample(t), plant.input_index
        u[[i[n] for n in ("f_dist_n", "f_dist_e", "f_dist_d")]] = sample.force_ned
        u[[i[n] for n in ("tau_dist_x", "tau_dist_y", "tau_dist_z")]] = sample.torque_frd
        u[i["payload_mass"]] = sample.payload_kg
    return inputs


@dataclass
class Trace:
    t: np.ndarray
    pos: np.ndarray
    ref: np.ndarray
    eta: np.ndarray
    eta_cmd: np.ndarray
    internals: list[dict[str, float]]
    thrust: np.ndarray
    eta_est: np.ndarray


def fly(config: EmulatorConfig, plant_params: dict, reference: Callable[[float], Setpoint], seconds: float,
        dt: float = 0.004, inputs: Callable[[float, Plant, np.ndarray], None] | None = None,
        start: tuple[float, float, float] = (1.0, 0.0, 0.0), sensors: SensorsConfig | None = None,
        controller: Controller | None = None) -> Trace:
    """Start in the air at `start` (NED), level, rotors in trim; fly `reference` for `seconds`.

    With `sensors`, the controller flies on the emulator's estimator fed by the bench's sensor
    models (HIL_SENSOR/HIL_GPS contents, no MAVLink); otherwise on the true state. `controller` replaces
    the configured one (a controller not registered, e.g. the template).
    """
    controller = controller or make_controller(config)
    estimator = Estimator(config.estimator) if sensors is not None else None
    suite = SensorSuite(sensors, Home(), 1.0 / dt, np.random.default_rng(7)) if sensors is not None else None
    mixer = Mixer(config.vehicle)
    params = dict(plant_params, init_pos_n=start[0], init_pos_e=start[1], init_pos_d=start[2])
    rows = []
    with Plant(params) as plant:
        o = plant.output_index
        u = np.zeros(len(plant.input_names))
        cmd_idx = [plant.input_index[f"motor_cmd_{i}"] for i in range(1, 5)]
        u[[plant.input_index[f"motor_health_{i}"] for i in range(1, 5)]] = 1.0
        u[cmd_idx] = mixer.commands(params.get("mass", 1.0) * 9.80665, np.zeros(3))
        plant.reset(params, initial_inputs=u)
        out = plant.outputs()
        t = 0.0
        t_us = 0
        airborne = False
        while t < seconds - 1e-9:
            state = VehicleState(out[[o["pos_n"], o["pos_e"], o["pos_d"]]].copy(),
                                 out[[o["vel_n"], o["vel_e"], o["vel_d"]]].copy(),
                                 out[[o["roll"], o["pitch"], o["yaw"]]].copy(),
                                 out[[o["rate_x"], o["rate_y"], o["rate_z"]]].copy())
            truth_state = state
            if estimator is not None and suite is not None:
                t_us += round(dt * 1e6)
                true = TrueState(t_us, state.pos_ned, state.vel_ned, out[[o["q_w"], o["q_x"], o["q_y"], o["q_z"]]],
                                 state.rates_frd, out[[o["specific_force_x"], o["specific_force_y"],
                                                       o["specific_force_z"]]])
                readings, fix = suite.step(true)
                estimator.on_sensors(readings)
                if fix is not None:
                    estimator.on_gps(fix, t_us)
                if not estimator.aligned:  # the controller waits for the estimator, the rotors hold trim
                    plant.set_inputs(u)
                    out = plant.step(dt)
                    continue
                e = estimator.estimate()
                state = VehicleState(e.pos_ned, e.vel_ned, e.eta, e.rates_frd)
            sp = reference(t)
            airborne = airborne or truth_state.pos_ned[2] < start[2] - 0.3
            result = controller.update(state, sp, dt, adapt=airborne or start[2] < 0)
            u[cmd_idx] = mixer.commands(result.thrust_n, result.torque_frd)
            if inputs is not None:
                inputs(t, plant, u)
            plant.set_inputs(u)
            out = plant.step(dt)
            t += dt
            rows.append((t, truth_state.pos_ned, sp.pos_ned, truth_state.eta, result.eta_cmd, result.internals,
                         result.thrust_n, state.eta))
    return Trace(np.array([r[0] for r in rows]), np.array([r[1] for r in rows]), np.array([r[2] for r in rows]),
                 np.array([r[3] for r in rows]), np.array([r[4] for r in rows]), [r[5] for r in rows],
                 np.array([r[6] for r in rows]), np.array([r[7] for r in rows]))
