"""The bench loop: scenario inputs → plant step → sensors → board → motor commands, with pacing.

It only steps, sends, waits and hands frames on; its parts are passed in (as RotorPy's `simulate()` takes them):
the world it simulates, the board, the pilot that decides each step, and the sinks. Lockstep with the emulator and
PX4 SITL (free-run until the first actuator reply); wall-clock real time with a board on its own clock, injected
link faults, or `paced=True`."""

from __future__ import annotations

import math
import time
import traceback
from collections.abc import Callable
from contextlib import nullcontext
from dataclasses import dataclass, field

from firmware_interface import hil_codec as codec
from firmware_interface.board import BoardError
from firmware_interface.geodesy import LocalFrame
from firmware_interface.link import LinkError, Message
from firmware_interface.link.faults import LinkFaults
from hil.boards.handle import BoardHandle
from hil.boards.target import GroundTruthUse
from hil.exit_codes import EXIT_BOARD, EXIT_EXPECT_FAILED, EXIT_INTERNAL, EXIT_INTERRUPTED, EXIT_OK
from hil.host.rt_priority import frozen_heap, realtime_priority
from hil.host.stop_signals import stop_requested
from hil.loop.board_io import board_io
from hil.loop.board_messages import decode_board_message
from hil.loop.frame import StepFrame
from hil.loop.pacing import Pacer
from hil.loop.pilot import Decision, Pilot, PilotView, RunAborted
from hil.loop.senders import Senders
from hil.loop.sink import Sink
from hil.loop.timing import LoopTiming
from hil.scenario.environment import Environment, EnvironmentSample
from hil.scenario.expressions import EvaluationError
from hil.sensors import SensorSuite
from plant_fmu import Plant, PlantError

Progress = Callable[[str, float, float, float], None]  # phase, bench time (s), fraction flown, real-time factor


@dataclass
class World:
    """What the bench simulates and the loop steps: the plant, its sensors, the environment acting on it, the
    local frame of the ground truth, the faults injected on the links to the board, and the other senders the
    board hears from (its battery, a ground station's joystick, and that ground station's loss)."""

    plant: Plant
    sensors: SensorSuite
    environment: Environment
    local_frame: LocalFrame
    link_faults: list[LinkFaults]
    senders: Senders = field(default_factory=Senders)


@dataclass
class LoopResult:
    exit_code: int
    reason: str
    internal_error: str | None  # the traceback of an error nobody expected


class Stepper:
    def __init__(self, world: World, board: BoardHandle, pilot: Pilot, sinks: list[Sink], dt_us: int,
                 paced: bool, truth_use: GroundTruthUse, progress: Progress | None = None,
                 speed_factor: float = 1.0) -> None:
        self.world, self.board, self.pilot, self.sinks = world, board, pilot, sinks
        self.dt_us, self.dt = dt_us, dt_us / 1e6  # the bench's clock is integer µs; the plant's step follows it
        self.paced, self.progress = paced, progress
        self.timing = LoopTiming()
        self.io = board_io(board, truth_use, world.local_frame, world.environment.steady, self.timing, world.sensors)
        self.pacer = Pacer(self.dt / speed_factor, self.timing)  # paced: a step every dt / speed_factor of wall time
        self.view = PilotView(board.command_session.report, board.command_session.link.name, self.emit, board.params)
        self.t_us = 0
        self.phase = ""  # the latest decision's phase and mission clock (for the progress line and messages)
        self.mission_t = -math.inf
        self.truth = world.plant.state()  # the true state after the latest step
        self.motors: tuple[float, ...] = (0.0,) * world.plant.rotor_count
        self.armed = False
        self.finished = False  # the pilot said the flight is over
        self.failsafe_texts: list[tuple[float, str]] = []  # the board's texts that say failsafe, with the time
        self._pending: StepFrame | None = None  # the last step's frame, handed to the sinks during the next step
        self._pending_inbox: list[Message] = []  # its board messages, decoded then too (off the board's wait)
        self._unseen: list[Message] = []  # the board's messages the pilot has not been shown yet
        self._cell_failed = False  # the scenario's battery cell failure has been set in the plant

    def run(self) -> LoopResult:
        started = time.perf_counter()
        board_cpu_s = self.board.cpu_s()
        reason, code, internal = "completed", int(EXIT_OK), None
        try:
            self.io.drain()  # what the board said before the first step (PX4's requests as it connects, the
            # wall-clock heartbeats of a board started elsewhere, as many as the start-up took seconds) belongs to
            # no step: recorded, it would make a recording depend on how fast the machine got here. A board that
            # speaks on the wall clock could still land after it; the emulator the bench starts sends one heartbeat
            # before the first HIL_SENSOR (--one-boot-heartbeat) for that reason. A board gone by now is a board
            # failure like any later one
            paced = realtime_priority(self.board.realtime_pids()) if self.paced else nullcontext("")
            with frozen_heap(), paced as note:
                if note:
                    self.emit(note)
                self._loop(started)
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
            internal = traceback.format_exc()
            reason, code = f"internal error {self.when()}: {type(exc).__name__}: {exc}", EXIT_INTERNAL
        finally:
            self._flush_pending()
            self._account_time(started, board_cpu_s)
        return LoopResult(code, reason, internal)

    def when(self) -> str:
        """The moment of the run, as a user reads it: mission time once the mission clock runs."""
        if math.isfinite(self.mission_t):
            return f"at mission time {self.mission_t:.2f} s"
        return f"at bench time {self.t_us * 1e-6:.2f} s (before the mission)"

    def emit(self, text: str) -> None:
        """A run event at the bench's time, to every sink."""
        for sink in self.sinks:
            sink.on_event(self.t_us, text)

    def _account_time(self, started: float, board_cpu_at_start_s: float | None) -> None:
        """Wall and simulated time of the run, and the CPU its board's process used meanwhile."""
        self.timing.wall_s, self.timing.sim_s = time.perf_counter() - started, self.t_us * 1e-6
        board_cpu_s = self.board.cpu_s()
        if board_cpu_at_start_s is not None and board_cpu_s is not None:
            self.timing.board_cpu_s = board_cpu_s - board_cpu_at_start_s

    def _loop(self, started: float) -> None:
        next_deadline = last_progress = time.perf_counter()
        planned: tuple[Decision, EnvironmentSample] | None = None  # decided during the last step's wait
        while True:
            if (stop := stop_requested()) is not None:  # its KeyboardInterrupt was lost where it landed
                raise KeyboardInterrupt(stop)
            self.timing.start()
            if planned is None and (self.finished or (planned := self._decide()) is None):
                return
            planned = self._step(*planned)
            if self.paced:
                next_deadline = self.pacer.sleep_until(next_deadline + self.pacer.period_s, self.t_us)
            if self.progress is not None and time.perf_counter() - last_progress > 0.25:
                last_progress = time.perf_counter()
                self.progress(self.phase, self.t_us * 1e-6, self.pilot.progress(),
                              self.t_us * 1e-6 / max(last_progress - started, 1e-9))

    def _decide(self) -> tuple[Decision, EnvironmentSample] | None:
        """The pilot's decision for the next step (its asks sent as that step begins) from the bench's current time,
        and the environment at its mission time; None once the flight is over."""
        view = self.view
        view.now_s, view.truth, view.outputs_armed = self.t_us * 1e-6, self.truth, self.armed
        view.messages, self._unseen = self._unseen, []
        decision = self.pilot.decide(view)
        if decision is None:
            self.finished = True  # asked once more it would have nothing to decide
            return None
        self.phase, self.mission_t = decision.phase, decision.mission_t
        environment = self.world.environment.sample(decision.mission_t if decision.flying else -1.0)
        self.world.plant.stage_environment(environment.motor_health, environment.wind_ned, environment.force_ned,
                                           environment.torque_frd, environment.payload_kg)
        self.timing.lap("phase_and_environment")
        return decision, environment

    def _step(self, decided: Decision, env: EnvironmentSample) -> tuple[Decision, EnvironmentSample] | None:
        """One step as `decided`: the plant, the sensors, the board's reply. Returns the next step's decision, made
        while the board computes this one: the pilot sees what the board said in this step's reply a step later."""
        timing, session, world = self.timing, self.board.hil_session, self.world
        if not world.senders.ground_station_lost(decided.mission_t):  # the bench's commands are a GCS's: they go
            for ask in decided.asks:  # before the step's frames, so a board on one link takes them in this step
                self.board.command_session.ask(ask)
        if not session.waits_for_replies:  # a board on its own clock: take the reply that came while we slept
            self._take_reply(session.await_reply())
            timing.lap("frame")
        mission_t = decided.mission_t
        world.plant.set_rotor_commands(self.motors)  # the rest of the inputs were staged at the decision
        if env.battery_fault is not None and not self._cell_failed:
            self._fail_cell(*env.battery_fault)
        world.plant.step(self.dt)
        outputs = world.plant.live()  # the frames come from it; the state kept is copied once they are sent
        self.t_us += self.dt_us
        for faults in world.link_faults:
            faults.now_s, faults.window_s = self.t_us * 1e-6, mission_t
        sent = timing.lap("plant")
        self._silence_ground_station(mission_t)  # then the battery's and the joystick's messages before the HIL
        # frames: a board on one link takes them in their step whenever its read wakes (after: a step late at times)
        others = world.senders.send(self.board.command_session, self.t_us, mission_t, outputs, self.emit)
        readings, gps = self.io.send_step(self.t_us, decided.reference, decided.board_offset_ned, outputs,
                                          mission_t)  # before the mission (-inf) no sensor fault acts
        self.truth = truth = world.plant.state()
        self._flush_pending()
        timing.lap("previous_step_messages_and_sinks")
        early = self._decide()
        waited_s = session.link.waited_s
        self._take_reply(session.await_reply())
        round_trip = timing.lap("board_reply", "wait_for_board", session.link.waited_s - waited_s) - sent
        self._pending = StepFrame(self.t_us, mission_t, decided.phase, truth, decided.reference, readings, gps,
                                  self.motors, self.armed, env, board_offset_ned=decided.board_offset_ned,
                                  step_wall_s=time.perf_counter() - timing.started, started_s=timing.started,
                                  round_trip_s=round_trip if session.lockstep else None, sent=others)
        self._pending_inbox = self.io.take_inbox()
        self._unseen += self._pending_inbox
        self._board_texts(self._pending_inbox)
        timing.lap("frame")
        return early

    def _silence_ground_station(self, mission_t: float) -> None:
        """In a ground-station loss nothing a ground station sends reaches the board: the bench's own heartbeat
        (its commands: `_decide`) and the relay's traffic stop; the HIL frames flow on."""
        lost = self.world.senders.ground_station_lost(mission_t)
        if lost != self.io.ground_station_lost:  # set as it changes: both start as False
            for session in self.board.sessions:
                session.ground_station_silent = lost
            self.io.ground_station_lost = lost

    def _fail_cell(self, cell: int, resistance_ohm: float, voltage_v: float) -> None:
        self.world.plant.set_battery_fault(cell, resistance_ohm, voltage_v)
        self._cell_failed = True
        self.emit(f"battery: cell {cell} fails {self.when()} (+{resistance_ohm:g} Ohm, -{voltage_v:g} V)")

    def _take_reply(self, actuators: codec.ActuatorOutputs | None) -> None:
        if actuators is not None:
            self.motors, self.armed = actuators.motors, actuators.armed

    def _board_texts(self, messages: list[Message]) -> None:
        """The board's texts of this step as events, at once, at the step's time (failsafes judged by them)."""
        for message in messages:
            if message.get_type() == "STATUSTEXT":
                self.emit(f"board: {message.text}")
                if "failsafe" in message.text.lower():
                    self.failsafe_texts.append((self.t_us * 1e-6, message.text))

    def _flush_pending(self) -> None:
        """The last step's frame, with its board messages decoded, to the sinks."""
        frame, self._pending = self._pending, None
        if frame is not None:
            frame.board = [p for p in (decode_board_message(m) for m in self._pending_inbox) if p is not None]
            self._pending_inbox = []
            self.timing.add_step(frame.step_wall_s, frame.round_trip_s)
            for sink in self.sinks:
                sink.on_step(frame)
