"""The bench loop: scenario inputs → plant step → sensors → board → motor commands, with pacing.

Phases: preflight (on the ground until the board accepts arming), offboard (switch, holding the
ground point), takeoff (climb to the reference's start, t < 0), mission (the reference, 0 ≤ t ≤
duration), landing, done. Lockstep with the emulator and PX4 SITL (free-run until the first
actuator reply); wall-clock real time with a serial board or `realtime=True`.
"""

from __future__ import annotations

import math
import time
import traceback
from collections.abc import Callable
from contextlib import nullcontext
from dataclasses import dataclass
from enum import StrEnum
from functools import cached_property
from typing import Any

import numpy as np
from pymavlink.dialects.v20.common import (
    MAV_LANDED_STATE_ON_GROUND,
    MAV_RESULT_ACCEPTED,
)

from firmware_interface import hil_codec as codec
from firmware_interface.board import ARM, DISARM, FORCE_DISARM, LAND, OFFBOARD, BoardError, BoardKind, Request
from firmware_interface.link import LinkError, Message
from firmware_interface.link.dialect import message_name
from firmware_interface.link.faults import FaultSpec, LinkFaults
from hil.boards.connect import BoardHandle
from hil.exit_codes import (
    EXIT_BOARD,
    EXIT_EXPECT_FAILED,
    EXIT_INTERNAL,
    EXIT_INTERRUPTED,
    EXIT_OK,
)
from hil.host.rt_priority import frozen_heap, realtime_priority
from hil.host.stop_signals import stop_requested
from hil.judge.flight_judge import FlightFailed, FlightJudge
from hil.judge.metrics import MetricsCollector
from hil.loop.board_messages import decode_board_message
from hil.loop.frame import StepFrame
from hil.loop.step_timer import StepTimer
from hil.scenario.environment import Environment, EnvironmentSample
from hil.scenario.expressions import EvaluationError
from hil.scenario.mission import MissionPlan
from hil.scenario.reference import RefSample
from hil.scenario.schema import Scenario
from hil.scenario.vehicles import plant_parameters
from hil.sensors import SensorsConfig, SensorSuite, TrueState
from plant_fmu import Plant, PlantError, PlantState

PREFLIGHT_TIMEOUT_S = 60.0  # simulated: PX4's GNSS checks alone need ~10 s of good data
ARM_RETRY_S = 1.0
OFFBOARD_TIMEOUT_S = 5.0
SETPOINTS_BEFORE_OFFBOARD_S = 0.2  # PX4 refuses offboard until setpoints are streaming
LAND_RETRY_S = 1.0
LANDING_TIMEOUT_S = 60.0  # from the land request to a confirmed disarm
DISARM_AFTER_LANDED_S = 3.0  # PX4 disarms by itself 2 s after landing (COM_DISARM_LAND); ask after this
DISARM_TIMEOUT_S = 5.0  # `end: disarm`: the forced disarm must be confirmed within this
LANDED_HEIGHT_M = 0.2  # the board says landed: the true vehicle must be this close to the ground
DISARMED_IN_FLIGHT_S = 0.25  # the board's outputs say disarmed this long during take-off or the mission
GROUNDED_S = 1.0  # stepping on after the disarm, so the board's own flight log records it before it is stopped
REALTIME_SLIP_S = 0.02  # paced run this far behind the wall clock (the machine stalled): go on from now



class Phase(StrEnum):
    """The bench's phases, in flight order (the values are what the recording says)."""

    PREFLIGHT = "preflight"  # on the ground until the board accepts arming
    OFFBOARD = "offboard"  # armed, streaming the ground point until offboard is accepted
    TAKEOFF = "takeoff"  # climbing to the reference's start (mission time < 0)
    MISSION = "mission"  # the reference, 0 ≤ t ≤ duration
    LANDING = "landing"  # the board's own land mode until it reports landed and disarmed
    DISARMING = "disarming"  # `end: disarm`: a forced disarm where the vehicle is
    GROUNDED = "grounded"  # landed and disarmed; the board's clock runs on GROUNDED_S
    DONE = "done"


FLYING = (Phase.TAKEOFF, Phase.MISSION, Phase.LANDING, Phase.DISARMING)


class RunAborted(RuntimeError):
    def __init__(self, reason: str, exit_code: int) -> None:
        super().__init__(reason)
        self.reason = reason
        self.exit_code = exit_code


@dataclass(frozen=True, slots=True)
class Decision:
    """What the phase decided for one step: the phase it flies in, the reference (None: no setpoint), the
    mission time both are sampled at, and the environment the plant steps through."""

    phase: Phase
    reference: RefSample | None
    mission_t: float
    environment: EnvironmentSample


@dataclass
class RunResult:
    exit_code: int
    reason: str
    metrics: dict[str, Any]


Sink = Callable[[StepFrame], None]


class Bench:
    def __init__(self, scenario: Scenario, board: BoardHandle, realtime: bool, sinks: list[Sink],
                 progress: Callable[[str, float, float, float], None] | None = None,
                 on_event: Callable[[int, str], None] | None = None) -> None:
        self.scenario = scenario
        self.board = board
        self.realtime = realtime or board.kind is BoardKind.HITL
        self.sinks = sinks
        self.progress = progress
        self.on_event = on_event
        self.dt_us = round(1e6 / scenario.rate_hz)  # the bench's clock is integer µs; the plant's step follows it
        self.dt = self.dt_us / 1e6  # (equal to 1 / rate_hz whenever the rate divides 1 MHz, as every shipped one)
        self.home = scenario.home
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
        board.session.reversible_motors = parameters.get("rotor_reversible", 0.0) > 0.5
        self.metrics = MetricsCollector(scenario.expect.settle_s if scenario.expect else 5.0)
        self.link_faults = self._inject_link_faults(rng.spawn(1)[0]) if scenario.faults.link else []
        self._disarmed_in_flight_since: float | None = None
        self._failsafe_texts: list[tuple[float, str]] = []
        # the emulator flying on the truth gets it with the sensors at float precision (ODOMETRY); PX4 SITL
        # gets HIL_STATE_QUATERNION for its log, a step behind (`BoardSession.send_ground_truth_ahead`)
        self.exact_truth = board.kind is BoardKind.EMULATOR and scenario.board.state_source == "truth"
        self.truth_for_log = board.kind is BoardKind.SITL
        self.own_command_link = board.commands is not board.session  # PX4 SITL's UDP link (`_step`, `_send_step`)
        self.t_us = 0
        self.phase = Phase.PREFLIGHT
        self._phase_since_s = 0.0
        self._next_request_s = 0.0
        self._landed_since_s: float | None = None
        self._params_reported = False
        self.board_offset_ned: np.ndarray | None = None  # board local frame - truth, from arming on
        self._mission_us: int | None = None  # the mission clock, integer µs like the bench's; None before take-off
        self.mission_t = -math.inf  # the same in seconds, what the reference and the environment are sampled at
        self.internal_error: str | None = None  # the traceback of an error nobody expected
        self.judge = FlightJudge()
        self.motors: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0)
        self.armed = False
        self.events: list[tuple[int, str]] = []
        self._started = time.perf_counter()
        self._pending: StepFrame | None = None  # the last step's frame, handed to the sinks during the next step
        self._pending_inbox: list[Message] = []  # its board messages, decoded then too (off the board's wait)
        self._timer = StepTimer(self.metrics.breakdown_s)
        self.plant = Plant(parameters)  # last: from here on `run` closes it, whatever happens
        try:
            self.state = self.plant.state()  # the true state after the latest step
        except BaseException:
            self.plant.close()
            raise

    def _inject_link_faults(self, rng: np.random.Generator) -> list[LinkFaults]:
        """The scenario's link faults on each link to the board. They are wall-clock effects (a board's
        failsafe counts real time), so the run is paced in real time and never waits for a reply."""
        specs = [FaultSpec(f.kind, f.direction, f.start_s, f.end_s, f.probability, f.burst_frames,
                           f.delay_ms / 1000.0, f.jitter_ms / 1000.0, f.byte_error_rate)
                 for f in self.scenario.faults.link]
        faults = []
        # one or two sessions; two streams are spawned either way (the RNG's draws do not depend on it)
        for session, stream in zip(self.board.sessions, rng.spawn(2), strict=False):
            session.link.faults = LinkFaults(specs, stream)
            session.wait_for_replies = False
            session.watchdog_s += session.link.faults.longest_outage_s()
            faults.append(session.link.faults)
        self.realtime = True
        return faults

    # --- the run -----------------------------------------------------------------
    def run(self) -> RunResult:
        self._started = time.perf_counter()
        board_cpu_s = self.board.cpu_s()
        reason, code = "completed", int(EXIT_OK)
        try:
            paced = realtime_priority(self.board.realtime_pids()) if self.realtime else nullcontext("")
            with frozen_heap(), paced as note:
                if note:
                    self._event(note)
                self._fly()
        except RunAborted as exc:
            reason, code = exc.reason, exc.exit_code
        except (BoardError, LinkError) as exc:
            reason, code = f"board/link failure: {exc}", EXIT_BOARD
        except PlantError as exc:
            reason, code = f"plant diverged {self.when()}: {exc}", EXIT_EXPECT_FAILED
        except EvaluationError as exc:  # the scenario's own expression failed mid-flight
            reason, code = f"a scenario expression failed: {exc} (mission time)", EXIT_EXPECT_FAILED
        except KeyboardInterrupt as exc:
            reason, code = f"interrupted ({exc.args[0] if exc.args else 'Ctrl-C'})", EXIT_INTERRUPTED
        except Exception as exc:
            self.internal_error = traceback.format_exc()
            reason, code = f"internal error {self.when()}: {type(exc).__name__}: {exc}", EXIT_INTERNAL
        finally:
            self._flush_pending()
            self._account_time(board_cpu_s)
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
        if self.board.commands.streams_stopped:
            metrics["board_streams_stopped"] = [message_name(i) for i in self.board.commands.streams_stopped]
        if self.board_offset_ned is not None:
            metrics["board_frame_offset_m"] = [float(v) for v in self.board_offset_ned]
        return RunResult(code, reason, metrics)

    def when(self) -> str:
        """The moment of the run, as a user reads it: mission time once the mission clock runs."""
        if math.isfinite(self.mission_t):
            return f"at mission time {self.mission_t:.2f} s"
        return f"at bench time {self.t_us * 1e-6:.2f} s (before the mission)"

    def _event(self, text: str) -> None:
        self.events.append((self.t_us, text))
        if self.on_event is not None:
            self.on_event(self.t_us, text)

    def _account_time(self, board_cpu_at_start_s: float | None) -> None:
        """Wall and simulated time of the run, and the CPU its board's process used meanwhile."""
        self.metrics.wall_s = time.perf_counter() - self._started
        self.metrics.sim_s = self.t_us * 1e-6
        board_cpu_s = self.board.cpu_s()
        if board_cpu_at_start_s is not None and board_cpu_s is not None:
            self.metrics.board_cpu_s = board_cpu_s - board_cpu_at_start_s

    def _fly(self) -> None:
        next_deadline = time.perf_counter()
        last_progress = time.perf_counter()
        total_s = self.plan.takeoff_s + self.plan.duration_s
        decided: Decision | None = None  # made during the last step's wait (`own_command_link`)
        while self.phase is not Phase.DONE:
            if (stop := stop_requested()) is not None:  # its KeyboardInterrupt was lost where it landed
                raise KeyboardInterrupt(stop)
            self._timer.start()
            if decided is None and (decided := self._decide()) is None:
                return
            decided = self._step(decided)
            if self.realtime:
                next_deadline = self._sleep_until(next_deadline + self.dt)
            if self.progress is not None and time.perf_counter() - last_progress > 0.25:
                last_progress = time.perf_counter()
                flown = min(max(self.mission_t + self.plan.takeoff_s, 0.0), total_s)  # take-off and mission
                self.progress(str(self.phase), self.t_us * 1e-6, flown / total_s,
                              self.t_us * 1e-6 / max(last_progress - self._started, 1e-9))

    @cached_property
    def _handlers(self) -> dict[Phase, Callable[[float], RefSample | None]]:
        """Each phase's part of a step, from the bench's time: what it asks of the board, and the reference."""
        return {Phase.PREFLIGHT: self._preflight, Phase.OFFBOARD: self._offboard, Phase.TAKEOFF: self._takeoff,
                Phase.MISSION: self._mission, Phase.LANDING: self._landing, Phase.DISARMING: self._disarming,
                Phase.GROUNDED: self._grounded}

    def _decide(self) -> Decision | None:
        """The phase's decision for the step from the bench's current time; None once the run is done."""
        reference = self._handlers[self.phase](self.t_us * 1e-6)
        if self.phase is Phase.DONE:
            return None
        environment = self.environment.sample(self.mission_t if self.phase in FLYING else -1.0)
        self._timer.lap("phase_and_environment")
        return Decision(self.phase, reference, self.mission_t, environment)

    def _advance_mission_clock(self) -> None:
        """One step on the mission clock: counted in integer µs, so it never drifts from the bench's."""
        assert self._mission_us is not None
        self._mission_us += self.dt_us
        self.mission_t = self._mission_us / 1e6

    # --- phases: each returns the reference to fly this step (None: no setpoint) ----
    def _last_texts(self, count: int) -> str:
        return "; ".join(t for _, t in self.board.commands.state.status_texts[-count:])

    def _request_every(self, now_s: float, period_s: float, request: Request) -> None:
        """Send a command now and again every `period_s` until its ACK arrives (the ACK is read per step)."""
        if now_s >= self._next_request_s:
            self.board.commands.request(request.command, request.params)
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
        if commands.acknowledged(ARM.command) == MAV_RESULT_ACCEPTED:
            self._align_board_frame()
            self._switch(Phase.OFFBOARD, now_s)
            self._next_request_s = now_s + SETPOINTS_BEFORE_OFFBOARD_S
        else:
            self._request_every(now_s, ARM_RETRY_S, ARM)
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
        ack = self.board.commands.acknowledged(OFFBOARD.command)
        if ack == MAV_RESULT_ACCEPTED:
            self._switch(Phase.TAKEOFF, now_s)
            self._mission_us = -round(self.plan.takeoff_s * 1e6)
            self.mission_t = self._mission_us / 1e6
        elif now_s - self._phase_since_s > OFFBOARD_TIMEOUT_S:
            texts = self._last_texts(2)
            raise RunAborted(f"offboard mode refused (MAV_RESULT {ack}){': ' + texts if texts else ''}", EXIT_BOARD)
        else:
            self._request_every(now_s, 0.5, OFFBOARD)
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

    def _judge_flight(self) -> None:
        """Leaving the ground, hitting it, tumbling: judged on the true state (events, then the end)."""
        state = self.state
        height, roll, pitch = -float(state.pos_ned[2]), float(state.rpy[0]), float(state.rpy[1])
        step = self.judge.mission_step if self.phase is Phase.MISSION else self.judge.take_off_step
        try:
            step(height, state.on_ground, roll, pitch, self.when())
        except FlightFailed as exc:
            self._event(str(exc))
            raise RunAborted(str(exc), EXIT_EXPECT_FAILED) from exc

    def _takeoff(self, now_s: float) -> RefSample | None:
        self._judge_armed(now_s)
        self._judge_flight()
        if self.mission_t >= 0:
            self._switch(Phase.MISSION, now_s)
        return self.plan.sample(self.mission_t)

    def _mission(self, now_s: float) -> RefSample | None:
        self._judge_armed(now_s)
        self._judge_flight()
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
        land_accepted = commands.acknowledged(LAND.command) == MAV_RESULT_ACCEPTED
        if not land_accepted:
            self._request_every(now_s, LAND_RETRY_S, LAND)
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
            self._request_every(now_s, 1.0, DISARM)
        return None

    def _board_landed(self) -> bool:
        extended = self.board.commands.state.latest.get("EXTENDED_SYS_STATE")
        return extended is not None and extended.landed_state == MAV_LANDED_STATE_ON_GROUND

    def _finish_on_ground(self, now_s: float) -> None:
        height = -float(self.state.pos_ned[2])
        if height > LANDED_HEIGHT_M:
            raise RunAborted(f"the board reported landed and disarmed at {now_s:.3f} s with the vehicle "
                             f"{height:.2f} m above the ground", EXIT_EXPECT_FAILED)
        self._event(f"disarmed on the ground at {now_s:.3f} s")
        self._switch(Phase.GROUNDED, now_s)

    def _grounded(self, now_s: float) -> RefSample | None:
        """Simulated time runs on a little after the disarm: in lockstep the board's logger only writes
        as its clock advances, and PX4's (SDLOG_MODE 1) closes its log on the disarm it has yet to see."""
        if now_s - self._phase_since_s >= GROUNDED_S:
            self._switch(Phase.DONE, now_s)
        return None

    def _disarming(self, now_s: float) -> RefSample | None:
        commands = self.board.commands
        confirmed = (commands.acknowledged(ARM.command) == MAV_RESULT_ACCEPTED
                     or not self.armed)
        if confirmed and now_s > self._phase_since_s:
            self._event(f"disarmed at {now_s:.3f} s (end: disarm)")
            self._switch(Phase.DONE, now_s)
            return None
        if now_s - self._phase_since_s > DISARM_TIMEOUT_S:
            raise RunAborted(f"disarm not confirmed within {DISARM_TIMEOUT_S:g} s: {self._last_texts(2)}",
                             EXIT_EXPECT_FAILED)
        self._request_every(now_s, 0.5, FORCE_DISARM)
        return self._end_point()

    def _align_board_frame(self) -> None:
        """Setpoints go to the board in its own local frame: the offset between its LOCAL_POSITION_NED and
        the true position, taken when it accepts arming (on the ground, at rest) and kept for the run."""
        local = self.board.commands.state.latest.get("LOCAL_POSITION_NED")
        truth = self.state.pos_ned
        if local is None:
            self._event("board sent no LOCAL_POSITION_NED before arming: setpoints in the bench's frame")
            self.board_offset_ned = np.zeros(3)
            return
        self.board_offset_ned = np.array((local.x, local.y, local.z)) - truth
        self._event("board frame: local origin offset [{:+.3f}, {:+.3f}, {:+.3f}] m (board - truth)".format(
            *self.board_offset_ned))

    def _sleep_until(self, deadline: float) -> float:
        """Wait for the step's wall-clock deadline; returns the deadline kept. After a stall longer than
        REALTIME_SLIP_S the schedule slips instead of catching up: a burst of steps would hand the board
        a burst of sensor frames and let the plant run many steps on one stale actuator reply, while a
        slip is a pause both sides see as one late frame. Lateness is taken when the step starts, so a sleep
        that overslept counts as much as a step before it that ran long."""
        remaining = deadline - time.perf_counter()
        if remaining > 0.0005:
            time.sleep(remaining - 0.0003)
        while time.perf_counter() < deadline:
            pass
        started = time.perf_counter()
        behind = started - deadline
        if behind > self.dt:
            self.metrics.add_late(self.t_us, behind, self._timer.longest)
        if behind > REALTIME_SLIP_S:
            self.metrics.add_slip(behind)
            deadline = started
        self.metrics.add_step_start(started, self.dt)
        return deadline

    # --- one step -----------------------------------------------------------------
    def _step(self, decided: Decision) -> Decision | None:
        """One step as `decided`: the plant, the sensors, the board's reply. With PX4 SITL (`own_command_link`)
        the phase decides the next step while PX4 computes this one, and that decision is returned (else
        None): PX4's commands, ACKs and states come on a UDP link its own thread serves, so no step of ours
        is the one they belong to, and its reply need not be in before the phase looks."""
        timer, session = self._timer, self.board.session
        if not session.waits_for_replies:  # a board on its own clock: take the reply that came while we slept
            actuators = session.await_reply()
            if actuators is not None:
                self.motors, self.armed = actuators.motors, actuators.armed
            timer.lap("frame")
        env, mission_t = decided.environment, decided.mission_t
        self.plant.set_input_groups(self.motors, env.motor_health, env.wind_ned, env.force_ned, env.torque_frd,
                                    env.payload_kg)
        self.plant.step(self.dt)
        self.state = state = self.plant.state()
        self.t_us += self.dt_us
        timer.lap("plant")
        truth = TrueState(self.t_us, state.pos_ned, state.vel_ned, state.q_wxyz, state.rates_frd,
                          state.specific_force_frd)
        readings, gps = self.sensors.step(truth, mission_t if mission_t > -math.inf else None)
        for faults in self.link_faults:
            faults.now_s, faults.window_s = self.t_us * 1e-6, mission_t
        sent = timer.lap("sensors")
        self._send_step(decided.reference, readings, gps, state)
        if decided.phase in FLYING:
            self._advance_mission_clock()
        early = self._decide() if self.own_command_link else None
        actuators = session.await_reply()
        t_reply = timer.lap("wait_for_board")
        round_trip = t_reply - sent if session.lockstep else None
        if actuators is not None:
            self.motors, self.armed = actuators.motors, actuators.armed
        self._pending = StepFrame(self.t_us, mission_t, decided.phase, state, decided.reference, readings, gps,
                                  self.motors, self.armed, env, [], time.perf_counter() - timer.started, round_trip)
        self._pending_inbox = self._take_inbox()
        self._board_texts(self._pending_inbox)
        timer.lap("frame")
        return early

    def _send_step(self, reference: RefSample | None, readings: codec.SensorReadings, gps: codec.GpsFix | None,
                   state: PlantState) -> None:
        """This step's frame out first, in one write; then what may overlap the board's computation: PX4's
        command link (the setpoint, its messages, our heartbeat), the ground-station relay, the previous
        step's board messages and sinks. A board with one link (the emulator, a serial board) gets the setpoint
        in that write, ahead of the sensors, and flies it this step. PX4 SITL reads its command link on a
        thread of its own, so a setpoint there never had a defined order against the sensor frame; it goes
        after, and the board waits for nothing but its sensors."""
        session, commands = self.board.session, self.board.commands
        session.link.begin_batch()
        if reference is not None and not self.own_command_link:
            self._send_setpoint(reference)
        session.send_step(readings, gps, self._local_truth(state) if self.exact_truth else None)
        session.link.flush()
        self._timer.lap("encode_and_send")
        if self.truth_for_log:
            session.send_ground_truth_ahead(self._ground_truth(state))
        if self.own_command_link:
            if reference is not None:
                self._send_setpoint(reference)
            commands.poll(0.0)
            commands.service(self.t_us * 1e-6 if session.lockstep else None)
        if self.board.gcs is not None:
            self._relay_gcs()
        self._timer.lap("command_link_and_relay")
        self._flush_pending()
        self._timer.lap("previous_step_messages_and_sinks")

    def _send_setpoint(self, reference: RefSample) -> None:
        """The reference in the board's own local frame (`board_offset_ned`, from arming on)."""
        offset = self.board_offset_ned if self.board_offset_ned is not None else 0.0
        self.board.commands.send_setpoint(self.t_us // 1000, tuple(reference.pos_ned + offset),
                                          tuple(reference.vel_ned), tuple(reference.acc_ned), reference.yaw)

    def _board_messages(self, frame: StepFrame, messages: list[Message]) -> list[tuple[str, dict[str, Any]]]:
        """The board's messages that came in `frame`'s step, decoded; its estimates (during the mission) are
        scored against that step's true state."""
        board = [p for p in (decode_board_message(m) for m in messages) if p is not None]
        if frame.phase != Phase.MISSION:
            return board
        for kind, payload in board:
            if kind == "LOCAL_POSITION_NED" and self.board_offset_ned is not None:
                self.metrics.add_estimate_error(np.array(payload["pos_ned"]) - self.board_offset_ned
                                                - frame.truth.pos_ned)
            elif kind == "ATTITUDE":
                self.metrics.add_attitude_estimate_error(np.array(payload["rpy"]) - frame.truth.rpy)
        return board

    def _board_texts(self, messages: list[Message]) -> None:
        """The board's texts of this step as events, at once: the next step's phase may follow from them."""
        for message in messages:
            if message.get_type() == "STATUSTEXT":
                self._event(f"board: {message.text}")
                if "failsafe" in message.text.lower():
                    self._failsafe_texts.append((self.t_us * 1e-6, message.text))

    def _flush_pending(self) -> None:
        """The last step's frame, with its board messages decoded, to the metrics and the sinks."""
        frame, self._pending = self._pending, None
        if frame is not None:
            frame.board = self._board_messages(frame, self._pending_inbox)
            self._pending_inbox = []
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

    def _take_inbox(self) -> list[Message]:
        """This step's messages from every link to the board, taken as they came (decoded later)."""
        messages = self.board.session.inbox
        self.board.session.inbox = []
        if self.own_command_link:
            messages += self.board.commands.inbox
            self.board.commands.inbox = []
        return messages

    def _local_truth(self, state: PlantState) -> codec.LocalTruth:
        """The true state for the emulator's exact-state path (ODOMETRY, float precision)."""
        return codec.LocalTruth(self.t_us, tuple(state.pos_ned.tolist()), tuple(state.vel_ned.tolist()),
                                tuple(state.q_wxyz.tolist()), tuple(state.rates_frd.tolist()))

    def _ground_truth(self, state: PlantState) -> codec.GroundTruth:
        """The true state as HIL_STATE_QUATERNION carries it (geodetic position), for PX4 SITL's log."""
        pos = state.pos_ned
        lat, lon, alt = self.home.frame.to_geodetic(float(pos[0]), float(pos[1]), float(pos[2]))
        vel = state.vel_ned
        return codec.GroundTruth(self.t_us, tuple(state.q_wxyz.tolist()), tuple(state.rates_frd.tolist()),
                                 lat, lon, alt, tuple(vel.tolist()), tuple(state.specific_force_frd.tolist()),
                                 float(np.linalg.norm(vel - self.environment.steady)))
