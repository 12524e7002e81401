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
from enum import StrEnum
from typing import Any

import numpy as np

from firmware_interface import hil_codec as codec
from firmware_interface.board import (
    FORCE_DISARM_MAGIC,
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_CMD_DO_SET_MODE,
    MAV_CMD_NAV_LAND,
    MAV_LANDED_STATE_ON_GROUND,
    MAV_RESULT_ACCEPTED,
    PX4_CUSTOM_MAIN_MODE_OFFBOARD,
    BoardError,
    BoardKind,
)
from firmware_interface.emulator.control import INTERNAL_KEYS
from firmware_interface.geodesy import LocalFrame
from firmware_interface.link import LinkError, Message
from firmware_interface.link.faults import FaultSpec, LinkFaults
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
LAND_RETRY_S = 1.0
LANDING_TIMEOUT_S = 60.0  # from the land request to a confirmed disarm
DISARM_AFTER_LANDED_S = 3.0  # PX4 disarms by itself 2 s after landing (COM_DISARM_LAND); ask after this
DISARM_TIMEOUT_S = 5.0  # `end: disarm`: the forced disarm must be confirmed within this
LANDED_HEIGHT_M = 0.2
DISARMED_IN_FLIGHT_S = 0.25  # the board's outputs say disarmed this long during take-off or the mission  # the board says landed: the true vehicle must be this close to the ground

EXIT_OK, EXIT_EXPECT_FAILED, EXIT_BOARD, EXIT_INTERRUPTED = 0, 1, 3, 130


class Phase(StrEnum):
    """The bench's phases, in flight order (the values are what the recording says)."""

    PREFLIGHT = "preflight"  # on the ground until the board accepts arming
    OFFBOARD = "offboard"  # armed, streaming the ground point until offboard is accepted
    TAKEOFF = "takeoff"  # climbing to the reference's start (mission time < 0)
    MISSION = "mission"  # the reference, 0 ≤ t ≤ duration
    LANDING = "landing"  # the board's own land mode until it reports landed and disarmed
    DISARMING = "disarming"  # `end: disarm`: a forced disarm where the vehicle is
    DONE = "done"


FLYING = (Phase.TAKEOFF, Phase.MISSION, Phase.LANDING, Phase.DISARMING)


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
    if kind == "EXTENDED_SYS_STATE":
        return kind, {"landed_state": msg.landed_state}
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
        self.link_faults = self._inject_link_faults(rng.spawn(1)[0]) if scenario.faults.link else []
        self._disarmed_in_flight_since: float | None = None
        self._failsafe_texts: list[tuple[float, str]] = []
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
        self._rpy = [o[n] for n in ("roll", "pitch", "yaw")]
        self._force = [o[n] for n in ("specific_force_x", "specific_force_y", "specific_force_z")]
        self.t_us = 0
        self.phase = Phase.PREFLIGHT
        self._phase_since_s = 0.0
        self._next_request_s = 0.0
        self._landed_since_s: float | None = None
        self._params_reported = False
        self.board_offset_ned: np.ndarray | None = None  # board local frame - truth, from arming on
        self.mission_t = -math.inf
        self.motors: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0)
        self.armed = False
        self.events: list[tuple[int, str]] = []
        self._started = time.perf_counter()
        self._pending: StepFrame | None = None  # the last step's frame, handed to the sinks during the next step
        self._sinks_started = 0.0

    def _inject_link_faults(self, rng: np.random.Generator) -> list[LinkFaults]:
        """The scenario's link faults on each link to the board. They are wall-clock effects (a board's
        failsafe counts real time), so the run is paced in real time and never waits for a reply."""
        specs = [FaultSpec(f.kind, f.direction, f.start_s, f.end_s, f.probability, f.burst_frames,
                           f.delay_ms / 1000.0, f.jitter_ms / 1000.0, f.byte_error_rate)
                 for f in self.scenario.faults.link]
        faults = []
        for session, stream in zip(self.board.sessions, rng.spawn(2)):
            session.link.faults = LinkFaults(specs, stream)
            session.wait_for_replies = False
            session.watchdog_s += session.link.faults.longest_outage_s()
            faults.append(session.link.faults)
        self.realtime = True
        return faults

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
        except KeyboardInterrupt as exc:
            reason, code = f"interrupted ({exc.args[0] if exc.args else 'Ctrl-C'})", EXIT_INTERRUPTED
        finally:
            self._flush_pending()
            self.metrics.wall_s = time.perf_counter() - start_wall
            self.metrics.sim_s = self.t_us * 1e-6
            self.plant.close()
        metrics = self.metrics.compute(self.board.session.link.counters, self.realtime, self.dt)
        metrics["phase_reached"] = str(self.phase)
        if self.link_faults:
            injected: dict[str, int] = {}
            for faults in self.link_faults:
                for key, count in faults.counts.items():
                    injected[key] = injected.get(key, 0) + count
            metrics["link_faults"] = {"injected": injected,
                                      "board_failsafe": [{"t_s": t, "text": text} for t, text in self._failsafe_texts]}
        if self.board.gcs is not None:
            metrics["gcs"] = self.board.gcs.counters()
        if self.board_offset_ned is not None:
            metrics["board_frame_offset_m"] = [float(v) for v in self.board_offset_ned]
        return RunResult(code, reason, metrics)

    def _event(self, text: str) -> None:
        self.events.append((self.t_us, text))
        if self.on_event is not None:
            self.on_event(self.t_us, text)

    def _fly(self) -> None:
        handlers = {Phase.PREFLIGHT: self._preflight, Phase.OFFBOARD: self._offboard, Phase.TAKEOFF: self._takeoff,
                    Phase.MISSION: self._mission, Phase.LANDING: self._landing, Phase.DISARMING: self._disarming}
        next_deadline = time.perf_counter()
        last_progress = time.perf_counter()
        total_s = self.plan.takeoff_s + self.plan.duration_s
        while self.phase is not Phase.DONE:
            now_s = self.t_us * 1e-6
            reference = handlers[self.phase](now_s)
            if self.phase is Phase.DONE:
                return
            self._step(reference, self.mission_t)
            if self.phase in FLYING:
                self.mission_t += self.dt
            if self.realtime:
                next_deadline += self.dt
                self._sleep_until(next_deadline)
            if self.progress is not None and time.perf_counter() - last_progress > 0.25:
                last_progress = time.perf_counter()
                self.progress(max(self.mission_t, -self.plan.takeoff_s) + self.plan.takeoff_s, total_s,
                              self.t_us * 1e-6 / max(last_progress - self._started, 1e-9))

    # --- phases: each returns the reference to fly this step (None: no setpoint) ----
    def _last_texts(self, count: int) -> str:
        return "; ".join(t for _, t in self.board.commands.state.status_texts[-count:])

    def _request_every(self, now_s: float, period_s: float, command: int, params: tuple[float, ...]) -> None:
        """Send a command now and again every `period_s` until its ACK arrives (the ACK is read per step)."""
        if now_s >= self._next_request_s:
            self.board.commands.request(command, params)
            self._next_request_s = now_s + period_s

    def _switch(self, phase: Phase, now_s: float) -> None:
        self._event(f"phase {self.phase} -> {phase} at {now_s:.3f} s")
        self.phase = phase
        self._phase_since_s = now_s
        self._next_request_s = now_s

    def _preflight(self, now_s: float) -> RefSample | None:
        commands = self.board.commands
        if now_s > PREFLIGHT_TIMEOUT_S:
            if commands.state.info is None:
                raise RunAborted(f"no heartbeat from the board on {commands.link.name} within "
                                 f"{PREFLIGHT_TIMEOUT_S:g} s of stepping", EXIT_BOARD)
            raise RunAborted(f"board did not arm within {PREFLIGHT_TIMEOUT_S:g} s: "
                             f"{self._last_texts(3) or 'no reason given'}", EXIT_BOARD)
        if commands.state.info is None:
            return None  # PX4 SITL opens its MAVLink ports only as its clock runs: keep stepping
        if not self._board_params_set(now_s):
            return None
        if commands.acknowledged(MAV_CMD_COMPONENT_ARM_DISARM) == MAV_RESULT_ACCEPTED:
            self._align_board_frame()
            self._switch(Phase.OFFBOARD, now_s)
            self._next_request_s = now_s + SETPOINTS_BEFORE_OFFBOARD_S
        else:
            self._request_every(now_s, ARM_RETRY_S, MAV_CMD_COMPONENT_ARM_DISARM, (1.0,))
        return None if self.phase is Phase.PREFLIGHT else self.plan.sample(-self.plan.takeoff_s)

    def _board_params_set(self, now_s: float) -> bool:
        """The parameters the bench owes the board (e.g. EKF2_GPS_DELAY for the simulated receiver), set and
        read back before arming; True once all are confirmed."""
        state = self.board.commands.state
        pending = {name: value for name, value in self.board.params.items()
                   if state.params.get(name) is None or abs(state.params[name] - value) > 1e-3 * max(abs(value), 1)}
        if not pending:
            if self.board.params and not self._params_reported:
                self._params_reported = True
                self._event("board parameters set: " + ", ".join(f"{n} = {v:g}" for n, v in self.board.params.items()))
            return True
        if now_s >= self._next_request_s:
            for name, value in pending.items():
                self.board.commands.set_param(name, value)
            self._next_request_s = now_s + ARM_RETRY_S
        return False

    def _offboard(self, now_s: float) -> RefSample | None:
        ack = self.board.commands.acknowledged(MAV_CMD_DO_SET_MODE)
        if ack == MAV_RESULT_ACCEPTED:
            self._switch(Phase.TAKEOFF, now_s)
            self.mission_t = -self.plan.takeoff_s
        elif now_s - self._phase_since_s > OFFBOARD_TIMEOUT_S:
            texts = self._last_texts(2)
            raise RunAborted(f"offboard mode refused (MAV_RESULT {ack}){': ' + texts if texts else ''}", EXIT_BOARD)
        else:
            self._request_every(now_s, 0.5, MAV_CMD_DO_SET_MODE,
                                (float(codec.MODE_FLAG_CUSTOM), float(PX4_CUSTOM_MAIN_MODE_OFFBOARD)))
        return self.plan.sample(self.mission_t if self.phase is Phase.TAKEOFF else -self.plan.takeoff_s)

    def _judge_armed(self, now_s: float) -> None:
        """A board that disarms in flight (a failsafe, a crash detector) ends the run: it would fall."""
        if self.armed:
            self._disarmed_in_flight_since = None
            return
        if self._disarmed_in_flight_since is None:
            self._disarmed_in_flight_since = now_s
        elif now_s - self._disarmed_in_flight_since > DISARMED_IN_FLIGHT_S:
            texts = self._last_texts(2)
            raise RunAborted(f"the board disarmed in flight at {self._disarmed_in_flight_since:.3f} s (mission time "
                             f"{self.mission_t:.2f} s){': ' + texts if texts else ''}", EXIT_EXPECT_FAILED)

    def _takeoff(self, now_s: float) -> RefSample | None:
        self._judge_armed(now_s)
        if self.mission_t >= 0:
            self._switch(Phase.MISSION, now_s)
        return self.plan.sample(self.mission_t)

    def _mission(self, now_s: float) -> RefSample | None:
        self._judge_armed(now_s)
        if self.mission_t <= self.plan.duration_s:
            return self.plan.sample(self.mission_t)
        self._switch(Phase.DISARMING if self.scenario.end == "disarm" else Phase.LANDING, now_s)
        return self._end_point()

    def _end_point(self) -> RefSample:
        return self.plan.sample(self.plan.duration_s)

    def _landing(self, now_s: float) -> RefSample | None:
        """The board lands by itself (PX4's land mode); done once it reports landed and disarmed."""
        commands = self.board.commands
        if now_s - self._phase_since_s > LANDING_TIMEOUT_S:
            extended = commands.state.latest.get("EXTENDED_SYS_STATE")
            landed = "no EXTENDED_SYS_STATE" if extended is None else f"landed_state {extended.landed_state}"
            texts = self._last_texts(2)
            raise RunAborted(f"landing timed out after {LANDING_TIMEOUT_S:g} s: board reports {landed}, "
                             f"{'armed' if commands.state.armed else 'disarmed'}{'; ' + texts if texts else ''}",
                             EXIT_EXPECT_FAILED)
        land_accepted = commands.acknowledged(MAV_CMD_NAV_LAND) == MAV_RESULT_ACCEPTED
        if not land_accepted:
            self._request_every(now_s, LAND_RETRY_S, MAV_CMD_NAV_LAND, ())
            return self._end_point()  # keep offboard fed until the board has switched to landing
        if not self._board_landed():
            self._landed_since_s = None
            return None
        if self._landed_since_s is None:
            self._landed_since_s = now_s
            self._event(f"board reports landed at {now_s:.3f} s")
        if not commands.state.armed:
            self._finish_on_ground(now_s)
        elif now_s - self._landed_since_s > DISARM_AFTER_LANDED_S:
            self._request_every(now_s, 1.0, MAV_CMD_COMPONENT_ARM_DISARM, (0.0,))
        return None

    def _board_landed(self) -> bool:
        extended = self.board.commands.state.latest.get("EXTENDED_SYS_STATE")
        return extended is not None and extended.landed_state == MAV_LANDED_STATE_ON_GROUND

    def _finish_on_ground(self, now_s: float) -> None:
        height = -float(self.plant.outputs()[self._pos][2])
        if height > LANDED_HEIGHT_M:
            raise RunAborted(f"the board reported landed and disarmed at {now_s:.3f} s with the vehicle "
                             f"{height:.2f} m above the ground", EXIT_EXPECT_FAILED)
        self._event(f"disarmed on the ground at {now_s:.3f} s")
        self._switch(Phase.DONE, now_s)

    def _disarming(self, now_s: float) -> RefSample | None:
        commands = self.board.commands
        confirmed = (commands.acknowledged(MAV_CMD_COMPONENT_ARM_DISARM) == MAV_RESULT_ACCEPTED
                     or not self.armed)
        if confirmed and now_s > self._phase_since_s:
            self._event(f"disarmed at {now_s:.3f} s (end: disarm)")
            self._switch(Phase.DONE, now_s)
            return None
        if now_s - self._phase_since_s > DISARM_TIMEOUT_S:
            raise RunAborted(f"disarm not confirmed within {DISARM_TIMEOUT_S:g} s: {self._last_texts(2)}",
                             EXIT_EXPECT_FAILED)
        self._request_every(now_s, 0.5, MAV_CMD_COMPONENT_ARM_DISARM, (0.0, FORCE_DISARM_MAGIC))
        return self._end_point()

    def _align_board_frame(self) -> None:
        """Setpoints go to the board in its own local frame: the offset between its LOCAL_POSITION_NED and
        the true position, taken when it accepts arming (on the ground, at rest) and kept for the run."""
        local = self.board.commands.state.latest.get("LOCAL_POSITION_NED")
        truth = self.plant.outputs()[self._pos]
        if local is None:
            self._event("board sent no LOCAL_POSITION_NED before arming: setpoints in the bench's frame")
            self.board_offset_ned = np.zeros(3)
            return
        self.board_offset_ned = np.array((local.x, local.y, local.z)) - truth
        self._event("board frame: local origin offset [{:+.3f}, {:+.3f}, {:+.3f}] m (board - truth)".format(
            *self.board_offset_ned))

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
        session = self.board.session
        if not session.waits_for_replies:  # a board on its own clock: take the reply that came while we slept
            actuators = session.await_reply()
            if actuators is not None:
                self.motors, self.armed = actuators.motors, actuators.armed
        env = self.environment.sample(mission_t if self.phase in FLYING else -1.0)
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
        for faults in self.link_faults:
            faults.now_s, faults.window_s = self.t_us * 1e-6, mission_t
        sent = time.perf_counter()
        session.link.begin_batch()  # setpoint first, then sensors, in one write: the board flies this step
        if reference is not None:  # on this step's setpoint whatever the scheduling (and deterministically)
            offset = self.board_offset_ned if self.board_offset_ned is not None else 0.0
            self.board.commands.send_setpoint(self.t_us // 1000, tuple(reference.pos_ned + offset),
                                              tuple(reference.vel_ned), tuple(reference.acc_ned), reference.yaw)
        session.send_step(readings, gps, self._ground_truth(out) if self.send_truth else None)
        session.link.flush()
        if self.board.commands is not session:
            self.board.commands.service(self.t_us * 1e-6 if session.lockstep else None)
        if self.board.gcs is not None:
            self._relay_gcs()
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
                if "failsafe" in payload["text"].lower():
                    self._failsafe_texts.append((self.t_us * 1e-6, payload["text"]))
            elif self.phase is not Phase.MISSION:
                continue
            elif kind == "LOCAL_POSITION_NED" and self.board_offset_ned is not None:
                self.metrics.add_estimate_error(np.array(payload["pos_ned"]) - self.board_offset_ned - out[self._pos])
            elif kind == "ATTITUDE":
                self.metrics.add_attitude_estimate_error(np.array(payload["rpy"]) - out[self._rpy])
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

    def _relay_gcs(self) -> None:
        """Board -> GCS for what came with the last reply; GCS -> board after this step's HIL frames."""
        gcs, board = self.board.gcs, self.board
        assert gcs is not None
        for session in board.sessions:
            if session.relay:
                gcs.to_gcs(session.relay)
                session.relay = []
        for frame in gcs.from_gcs():
            board.commands.link.send_frame(frame)

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
