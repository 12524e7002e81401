"""The bench loop: scenario inputs → plant step → sensors → board → motor commands, with pacing.

Phases: preflight (on the ground until the board accepts arming), offboard (switch, holding the
ground point), takeoff (climb to the reference's start, t < 0), mission (the reference, 0 ≤ t ≤
duration), landing, done. Lockstep with the emulator and PX4 SITL (free-run until the first
actuator reply); wall-clock real time with a serial board or `realtime=True`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from firmware_interface import hil_codec as codec
from firmware_interface.geodesy import LocalFrame
from firmware_interface.board import MAV_CMD_COMPONENT_ARM_DISARM, MAV_CMD_DO_SET_MODE, BoardError, BoardKind
from firmware_interface.board import PX4_CUSTOM_MAIN_MODE_OFFBOARD, MAV_RESULT_ACCEPTED
from firmware_interface.emulator.control import INTERNAL_KEYS
from firmware_interface.link import LinkError, Message
from hil.connect import BoardHandle
from hil.frame import StepFrame
from hil.metrics import MetricsCollector
from hil.scenario.environment import Environment
from hil.scenario.mission import MissionPlan
from hil.scenario.reference import RefSample
from hil.scenario.schema import Scenario
from hil.scenario.vehicles import plant_parameters
from hil.sensors import Home, SensorsConfig, SensorSuite, TrueState
from plant_fmu import Plant, PlantError

PREFLIGHT_TIMEOUT_S = 60.0  # simulated: PX4's GNSS checks alone need ~10 s of good data
ARM_RETRY_S = 1.0
OFFBOARD_TIMEOUT_S = 5.0
SETPOINTS_BEFORE_OFFBOARD_S = 0.2  # PX4 refuses offboard until setpoints are streaming
LANDING_TIMEOUT_S = 60.0

EXIT_OK, EXIT_EXPECT_FAILED, EXIT_BOARD, EXIT_INTERRUPTED = 0, 1, 3, 130


class RunAborted(RuntimeError):
    def __init__(self, reason: str, exit_code: int) -> None:
        super().__init__(reason)
        self.reason = reason
        self.exit_code = exit_code


@dataclass
class RunResult:
    exit_code: int
    reason: str
    metrics: dict[str, Any]


Sink = Callable[[StepFrame], None]


def _board_payload(msg: Message) -> tuple[str, dict[str, Any]] | None:
    kind = msg.get_type()
    if kind == "ATTITUDE_TARGET":
        return kind, {"q": list(msg.q), "thrust": msg.thrust}
    if kind == "DEBUG_FLOAT_ARRAY":
        keys = INTERNAL_KEYS.get(msg.name, ())
        values = dict(zip(keys, msg.data)) if keys else {f"v{i}": v for i, v in enumerate(msg.data) if v}
        return kind, {"name": msg.name, "values": values}
    if kind == "HEARTBEAT":
        return kind, {"armed": bool(msg.base_mode & codec.MODE_FLAG_ARMED), "custom_mode": msg.custom_mode,
                      "system_status": msg.system_status}
    if kind == "STATUSTEXT":
        return kind, {"severity": msg.severity, "text": msg.text}
    if kind == "COMMAND_ACK":
        return kind, {"command": msg.command, "result": msg.result}
    if kind == "LOCAL_POSITION_NED":
        return kind, {"pos_ned": [msg.x, msg.y, msg.z], "vel_ned": [msg.vx, msg.vy, msg.vz]}
    if kind == "ATTITUDE":
        return kind, {"rpy": [msg.roll, msg.pitch, msg.yaw]}
    return None


class Bench:
    def __init__(self, scenario: Scenario, board: BoardHandle, realtime: bool, sinks: list[Sink],
                 progress: Callable[[float, float, float], None] | None = None,
                 on_event: Callable[[int, str], None] | None = None) -> None:
        self.scenario = scenario
        self.board = board
        self.realtime = realtime or board.kind is BoardKind.HITL
        self.sinks = sinks
        self.progress = progress
        self.on_event = on_event
        self.dt = 1.0 / scenario.rate_hz
        self.dt_us = int(round(1e6 / scenario.rate_hz))
        self.home = Home(scenario.home.lat_deg, scenario.home.lon_deg, scenario.home.alt_msl_m)
        self._local_frame = LocalFrame(self.home.lat_deg, self.home.lon_deg, self.home.alt_msl_m)
        rng = np.random.default_rng(scenario.seed)
        sensor_rng, env_rng = rng.spawn(2)
        sensors = SensorsConfig.model_validate({**scenario.sensors.model_dump(),
                                                "faults": [*scenario.sensors.faults, *scenario.faults.sensors]})
        self.sensors = SensorSuite(sensors, self.home, scenario.rate_hz, sensor_rng)
        self.environment = Environment(scenario, self.dt, env_rng)
        self.plan = MissionPlan.build(scenario)
        # the vehicle waits on the ground facing the mission's first heading (no yaw step at take-off)
        parameters = {"init_yaw": self.plan.sample(-self.plan.takeoff_s).yaw,
                      **plant_parameters(scenario.vehicle.preset, scenario.vehicle.overrides)}
        self.plant = Plant(parameters)
        board.session.reversible_motors = parameters.get("rotor_reversible", 0.0) > 0.5
        self.metrics = MetricsCollector(scenario.expect.settle_s if scenario.expect else 5.0)
        self.send_truth = board.kind is BoardKind.SITL or (
            board.kind is BoardKind.EMULATOR and scenario.board.state_source == "truth")
        self._inputs = np.zeros(len(Plant.INPUT_NAMES))
        idx = self.plant.input_index
        self._motor_idx = [idx[f"motor_cmd_{i}"] for i in range(1, 5)]
        self._health_idx = [idx[f"motor_health_{i}"] for i in range(1, 5)]
        self._wind_idx = [idx[n] for n in ("wind_n", "wind_e", "wind_d")]
        self._force_idx = [idx[n] for n in ("f_dist_n", "f_dist_e", "f_dist_d")]
        self._torque_idx = [idx[n] for n in ("tau_dist_x", "tau_dist_y", "tau_dist_z")]
        self._payload_idx = idx["payload_mass"]
        o = self.plant.output_index
        self._o = o
        self._pos = [o[n] for n in ("pos_n", "pos_e", "pos_d")]
        self._vel = [o[n] for n in ("vel_n", "vel_e", "vel_d")]
        self._quat = [o[n] for n in ("q_w", "q_x", "q_y", "q_z")]
        self._rates = [o[n] for n in ("rate_x", "rate_y", "rate_z")]
        self._force = [o[n] for n in ("specific_force_x", "specific_force_y", "specific_force_z")]
        self.t_us = 0
        self.phase = "preflight"
        self.mission_t = -math.inf
        self.motors: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0)
        self.armed = False
        self.events: list[tuple[int, str]] = []
        self._started = time.perf_counter()
        self._pending: StepFrame | None = None  # the last step's frame, handed to the sinks during the next step
        self._sinks_started = 0.0

    # --- the run -----------------------------------------------------------------
    def run(self) -> RunResult:
        start_wall = self._started = time.perf_counter()
        reason, code = "completed", EXIT_OK
        try:
            self._fly()
        except RunAborted as exc:
            reason, code = exc.reason, exc.exit_code
        except (BoardError, LinkError) as exc:
            reason, code = f"board/link failure: {exc}", EXIT_BOARD
        except PlantError as exc:
            reason, code = f"plant diverged: {exc}", EXIT_EXPECT_FAILED
        except KeyboardInterrupt:
            reason, code = "interrupted (Ctrl-C)", EXIT_INTERRUPTED
        finally:
            self._flush_pending()
            self.metrics.wall_s = time.perf_counter() - start_wall
            self.metrics.sim_s = self.t_us * 1e-6
            self.plant.close()
        metrics = self.metrics.compute(self.board.session.link.counters, self.realtime, self.dt)
        metrics["phase_reached"] = self.phase
        return RunResult(code, reason, metrics)

    def _event(self, text: str) -> None:
        self.events.append((self.t_us, text))
        if self.on_event is not None:
            self.on_event(self.t_us, text)

    def _fly(self) -> None:
        commands = self.board.commands
        next_arm_try = 0.0
        next_mode_try = 0.0
        phase_since = 0.0
        landing = None
        on_ground_since: float | None = None
        next_deadline = time.perf_counter()
        last_progress = time.perf_counter()
        total_s = self.plan.takeoff_s + self.plan.duration_s
        while True:
            now_s = self.t_us * 1e-6
            # --- phase logic (commands are requests: their ACKs arrive over the next steps) ---
            if self.phase == "preflight":
                if now_s > PREFLIGHT_TIMEOUT_S:
                    texts = "; ".join(t for _, t in commands.state.status_texts[-3:]) or "no reason given"
                    raise RunAborted(f"board did not arm within {PREFLIGHT_TIMEOUT_S:g} s: {texts}", EXIT_BOARD)
                ack = commands.acknowledged(MAV_CMD_COMPONENT_ARM_DISARM)
                if ack == MAV_RESULT_ACCEPTED:
                    self._switch("offboard", now_s)
                    phase_since = now_s
                    next_mode_try = now_s + SETPOINTS_BEFORE_OFFBOARD_S
                elif now_s >= next_arm_try:
                    commands.request(MAV_CMD_COMPONENT_ARM_DISARM, (1.0,))
                    next_arm_try = now_s + ARM_RETRY_S
            elif self.phase == "offboard":
                ack = commands.acknowledged(MAV_CMD_DO_SET_MODE)
                if ack == MAV_RESULT_ACCEPTED:
                    self._switch("takeoff", now_s)
                    self.mission_t = -self.plan.takeoff_s
                elif now_s - phase_since > OFFBOARD_TIMEOUT_S:
                    texts = "; ".join(t for _, t in commands.state.status_texts[-2:])
                    raise RunAborted(f"offboard mode refused (MAV_RESULT {ack}){': ' + texts if texts else ''}",
                                     EXIT_BOARD)
                elif now_s >= next_mode_try:
                    commands.request(MAV_CMD_DO_SET_MODE, (float(codec.MODE_FLAG_CUSTOM),
                                                           float(PX4_CUSTOM_MAIN_MODE_OFFBOARD)))
                    next_mode_try = now_s + 0.5
            elif self.phase == "takeoff" and self.mission_t >= 0:
                self._switch("mission", now_s)
            elif self.phase == "mission" and self.mission_t > self.plan.duration_s:
                if self.scenario.end == "disarm":
                    commands.request(MAV_CMD_COMPONENT_ARM_DISARM, (0.0,))
                    self._switch("done", now_s)
                    self._step(None, self.mission_t)
                    return
                ref = self.plan.sample(self.plan.duration_s)
                landing = self.plan.landing(self.plant.outputs()[self._pos].copy(), ref.yaw)
                self._switch("landing", now_s)
                phase_since = now_s
            elif self.phase == "landing":
                if self.plant.on_ground:
                    on_ground_since = now_s if on_ground_since is None else on_ground_since
                if (on_ground_since is not None and now_s - on_ground_since > 1.0) or now_s - phase_since > LANDING_TIMEOUT_S:
                    commands.request(MAV_CMD_COMPONENT_ARM_DISARM, (0.0,))
                    self._switch("done", now_s)
                    self._step(None, self.mission_t)
                    return
            reference = self._reference(landing, now_s - phase_since)
            self._step(reference, self.mission_t)
            if self.phase in ("takeoff", "mission", "landing"):
                self.mission_t += self.dt
            if self.realtime:
                next_deadline += self.dt
                self._sleep_until(next_deadline)
            if self.progress is not None and time.perf_counter() - last_progress > 0.25:
                last_progress = time.perf_counter()
                self.progress(max(self.mission_t, -self.plan.takeoff_s) + self.plan.takeoff_s, total_s,
                              self.t_us * 1e-6 / max(last_progress - self._started, 1e-9))

    def _switch(self, phase: str, now_s: float) -> None:
        self._event(f"phase {self.phase} -> {phase} at {now_s:.3f} s")
        self.phase = phase

    def _reference(self, landing: Any, landing_t: float) -> RefSample | None:
        if self.phase in ("takeoff", "mission"):
            return self.plan.sample(self.mission_t)
        if self.phase == "landing" and landing is not None:
            return landing.sample(landing_t)
        if self.phase == "offboard":
            return self.plan.sample(-self.plan.takeoff_s)
        return None

    def _sleep_until(self, deadline: float) -> None:
        now = time.perf_counter()
        if now > deadline + self.dt:
            self.metrics.late_steps += 1
        remaining = deadline - now
        if remaining > 0.0005:
            time.sleep(remaining - 0.0003)
        while time.perf_counter() < deadline:
            pass
        self.metrics.step_starts.append(time.perf_counter())

    # --- one step -----------------------------------------------------------------
    def _step(self, reference: RefSample | None, mission_t: float) -> None:
        step_start = time.perf_counter()
        env = self.environment.sample(mission_t if self.phase in ("takeoff", "mission", "landing") else -1.0)
        u = self._inputs
        u[self._motor_idx] = self.motors
        u[self._health_idx] = env.motor_health
        u[self._wind_idx] = env.wind_ned
        u[self._force_idx] = env.force_ned
        u[self._torque_idx] = env.torque_frd
        u[self._payload_idx] = env.payload_kg
        t_env = time.perf_counter()
        self.plant.set_inputs(u)
        out = self.plant.step(self.dt)
        self.t_us += self.dt_us
        t_plant = time.perf_counter()
        truth = TrueState(self.t_us, out[self._pos], out[self._vel], out[self._quat], out[self._rates], out[self._force])
        readings, gps = self.sensors.step(truth, mission_t if mission_t > -math.inf else None)
        session = self.board.session
        sent = time.perf_counter()
        session.link.begin_batch()  # setpoint first, then sensors, in one write: the board flies this step
        if reference is not None:  # on this step's setpoint whatever the scheduling (and deterministically)
            self.board.commands.send_setpoint(self.t_us // 1000, tuple(reference.pos_ned), tuple(reference.vel_ned),
                                              tuple(reference.acc_ned), reference.yaw)
        session.send_step(readings, gps, self._ground_truth(out) if self.send_truth else None)
        session.link.flush()
        self._flush_pending()  # the previous step's sinks run while the board computes this one
        t_sent = time.perf_counter()
        actuators = session.await_reply()
        t_reply = time.perf_counter()
        round_trip = t_reply - sent if session.lockstep else None
        if actuators is not None:
            self.motors, self.armed = actuators.motors, actuators.armed
        board = [p for p in (_board_payload(m) for m in self._drain_inbox()) if p is not None]
        for kind, payload in board:
            if kind == "STATUSTEXT":
                self._event(f"board: {payload['text']}")
        frame = StepFrame(self.t_us, mission_t, self.phase, out.copy(), self.plant.on_ground, reference, readings, gps,
                          self.motors, self.armed, env, board, time.perf_counter() - step_start, round_trip)
        self._pending = frame
        b = self.metrics.breakdown_s
        b["environment"] += t_env - step_start
        b["plant"] += t_plant - t_env
        b["sensors"] += sent - t_plant
        b["encode_and_send"] += self._sinks_started - sent
        b["sinks_of_previous_step"] += t_sent - self._sinks_started
        b["wait_for_board"] += t_reply - t_sent
        b["frame"] += time.perf_counter() - t_reply

    def _flush_pending(self) -> None:
        self._sinks_started = time.perf_counter()
        frame, self._pending = self._pending, None
        if frame is not None:
            self.metrics.add(frame)
            for sink in self.sinks:
                sink(frame)

    def _drain_inbox(self) -> list[Message]:
        messages = self.board.session.inbox
        self.board.session.inbox = []
        if self.board.commands is not self.board.session:
            messages += self.board.commands.inbox
            self.board.commands.inbox = []
            self.board.commands.poll(0.0)
        return messages

    def _ground_truth(self, out: np.ndarray) -> codec.GroundTruth:
        pos = out[self._pos]
        lat, lon, alt = self._local_frame.to_geodetic(float(pos[0]), float(pos[1]), float(pos[2]))
        vel = out[self._vel]
        return codec.GroundTruth(self.t_us, tuple(out[self._quat].tolist()), tuple(out[self._rates].tolist()),
                                 lat, lon, alt, tuple(vel.tolist()), tuple(out[self._force].tolist()),
                                 float(np.linalg.norm(vel - self.environment.steady)))
