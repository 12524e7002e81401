"""The emulated flight controller: PX4's HIL protocol on one side, the paper's controllers inside, and to a
ground station what PX4 answers it (modes, commands, missions, parameters, telemetry).

Like PX4 with SYS_HITL=1 it sends a 1 Hz HEARTBEAT (autopilot PX4, its multirotor type, HIL_ENABLED; before the
first HIL_SENSOR on the wall clock, or only once for a peer that waits on the port from the start), takes
HIL_SENSOR / HIL_GPS (and, as truth when configured, ODOMETRY in the local frame at float precision, or
PX4 SITL's HIL_STATE_QUATERNION, whose integer lat/lon, mm and cm/s quantise it) and answers each
HIL_SENSOR with exactly one HIL_ACTUATOR_CONTROLS (lockstep flag set, time_usec echoed, as PX4 SITL does).
The commander (`commander.py`) keeps the flight mode and answers commands; the navigator (`navigator.py`)
turns the mode into the reference the controller tracks; `mission_protocol.py` serves missions. It knows
only MAVLink bytes and its own configuration, never the plant.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np
from pymavlink.dialects.v20.common import (
    MAV_CMD_GET_HOME_POSITION,
    MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES,
    MAV_CMD_REQUEST_MESSAGE,
    MAV_CMD_SET_MESSAGE_INTERVAL,
    MAV_LANDED_STATE_IN_AIR,
    MAV_LANDED_STATE_LANDING,
    MAV_LANDED_STATE_ON_GROUND,
    MAV_LANDED_STATE_TAKEOFF,
    MAV_PROTOCOL_CAPABILITY_COMMAND_INT,
    MAV_PROTOCOL_CAPABILITY_MAVLINK2,
    MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT,
    MAV_PROTOCOL_CAPABILITY_MISSION_INT,
    MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT,
    MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_DENIED,
    MAV_RESULT_UNSUPPORTED,
    MAV_SEVERITY_CRITICAL,
    MAVLINK_MSG_ID_AUTOPILOT_VERSION,
    MAVLINK_MSG_ID_GPS_RAW_INT,
    MAVLINK_MSG_ID_HOME_POSITION,
    MAVLINK_MSG_ID_MISSION_CURRENT,
    MAVLINK_MSG_ID_SYS_STATUS,
)

from firmware_interface import hil_codec as codec
from firmware_interface.emulator.commander import Command, Commander
from firmware_interface.emulator.config import EmulatorConfig
from firmware_interface.emulator.control import ControlOutput, VehicleState
from firmware_interface.emulator.control.registry import make_controller
from firmware_interface.emulator.estimator import Estimator, estimate_of
from firmware_interface.emulator.failsafe import Failsafes
from firmware_interface.emulator.flight import Flight
from firmware_interface.emulator.geometry import quat_to_euler
from firmware_interface.emulator.health import Health
from firmware_interface.emulator.mission_protocol import MISSION_MESSAGES, MissionServer
from firmware_interface.emulator.mixer import Mixer
from firmware_interface.emulator.navigator import NAVIGATOR_PERIOD_US
from firmware_interface.emulator.offboard import OffboardInput
from firmware_interface.emulator.params import ParameterServer
from firmware_interface.emulator.px4_params import Px4Values
from firmware_interface.emulator.step_read import SETPOINT, TARGET_SYSTEM, TRUTH, StepReader
from firmware_interface.emulator.telemetry import Telemetry
from firmware_interface.emulator.truth import OdometryReader
from firmware_interface.geodesy import LocalFrame
from firmware_interface.link import Link, LinkLost, Message
from firmware_interface.px4_modes import FlightMode
from firmware_interface.statustext import STATUSTEXT_CHUNK, text_chunks

# what a GCS may use
CAPABILITIES = (MAV_PROTOCOL_CAPABILITY_MAVLINK2 | MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
                | MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED | MAV_PROTOCOL_CAPABILITY_COMMAND_INT
                | MAV_PROTOCOL_CAPABILITY_MISSION_INT | MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT)
FLIGHT_SW_VERSION = (0 << 24) | (1 << 16) | (0 << 8) | 255  # hil-bench emulator 0.1.0, release


class EmulatedBoard(Flight):
    def __init__(self, link: Link, config: EmulatorConfig, clock: Callable[[], float] = time.monotonic,
                 repeat_boot_heartbeat: bool = True) -> None:
        self.link = link
        self.config = config
        self.clock = clock
        # before the first HIL_SENSOR: a heartbeat each wall-clock second, for a peer that may come at any time;
        # False: only the first, for a peer that holds the port before the emulator starts and waits for it (the
        # bench's pty). Its later ones could fall after the bench's pre-step drain, into a recorded step.
        self.repeat_boot_heartbeat = repeat_boot_heartbeat
        self.link.encoder.system_id = config.system_id
        self.link.encoder.component_id = 1
        self.controller = make_controller(config)
        self.mixer = Mixer(config.vehicle)
        self.estimator = Estimator(config.estimator, config.vehicle.g)
        self.params = Px4Values(config.params)
        self.truth: VehicleState | None = None  # the latest true state received (state_source truth)
        self.odometry = OdometryReader()
        self.last_fix: codec.GpsFix | None = None
        self.last_fix_us = 0
        self.last_sensor_t_us: int | None = None
        self.last_sensor_wall = clock()
        self.last_heartbeat: float | None = None  # wall-clock time of the last boot heartbeat
        self.boot_us: int | None = None
        self.motors_stopped = np.zeros(len(config.vehicle.rotors))  # the reply's motors while not flying
        self.last_control: ControlOutput | None = None
        self.stop_reason = ""
        self._text_id = 0
        self.offboard = OffboardInput()
        self.missions = MissionServer(config.system_id, self._send, self.status, self._mission_changed)
        self.commander = Commander(self)
        self.health = Health(self)
        self.failsafes = Failsafes(self)
        super().__init__()
        self.telemetry = Telemetry(self)
        self.param_server = ParameterServer(self)
        self.step_reader = StepReader()
        self.link.whole_frame_reader = self._read_step

    # --- main loop ----------------------------------------------------------------------------------------
    def run(self, should_stop: Callable[[], bool] = lambda: False) -> str:
        """Serve the link until it is lost or `should_stop()`; returns why it stopped."""
        try:
            while not should_stop():
                self.serve_once(0.05)
        except LinkLost as exc:
            self.stop_reason = f"link lost: {exc.reason}"
            return self.stop_reason
        self.stop_reason = "stopped"
        return self.stop_reason

    def serve_once(self, timeout_s: float) -> None:
        """One turn of the loop: the wall clock's business, then what one read brought, answered in one write."""
        self._housekeeping()
        self._answer(timeout_s)

    def _housekeeping(self) -> None:
        now = self.clock()
        last = self.last_heartbeat
        boot_beat = last is None or (self.repeat_boot_heartbeat and now - last >= 1.0)
        if self.last_sensor_t_us is None and boot_beat:  # no simulation clock yet
            self.telemetry.heartbeat()
            self.last_heartbeat = now
        if self.armed and self._sensors_silent_at(now):
            # what came while this process waited for a CPU first: a starved emulator is no lost link
            self._answer(0.0)
            if self.armed and self._sensors_silent_at(now):
                self.disarm()
                self.status(MAV_SEVERITY_CRITICAL,
                            f"Failsafe: no HIL_SENSOR for {self.config.failsafe_s:g} s, disarming")
        self.missions.service()

    def _sensors_silent_at(self, now: float) -> bool:
        failsafe_s = self.config.failsafe_s
        return failsafe_s is not None and now - self.last_sensor_wall > failsafe_s

    def _answer(self, timeout_s: float) -> None:
        """What one read within `timeout_s` brings, answered in one write: the bench wakes once a step, for the
        reply with that step's telemetry, instead of once for each message. A lockstep step's read is handled as
        the link reads it (`_read_step`), the rest message by message."""
        self.link.begin_batch()
        try:
            for msg in self.link.receive(timeout_s):
                self.handle(msg)
        finally:
            self.link.flush()

    def _read_step(self, data: bytes) -> tuple[int, ...]:
        """The link's reader of a read that is one lockstep step of the bench's (`step_read`): its setpoint, its
        ODOMETRY, its HIL_SENSOR, handled as `handle` handles their messages, without making them. () leaves the
        read to the scanner."""
        reader = self.step_reader
        found = reader.read(data)
        if found < 0:
            return ()
        if found == 0:
            self._on_sensor_frame(data)
            return (len(data),)
        setpoint_end, truth_end, end = reader.ends.tolist()
        if found & SETPOINT and reader.setpoint[TARGET_SYSTEM] == self.config.system_id:
            self.offboard.take(reader.setpoint, self.now_us)
        if found & TRUTH:
            self.truth = self.odometry.state(data[setpoint_end:truth_end])
        self._on_sensor_frame(data[truth_end:])
        if found == SETPOINT:
            return (setpoint_end, end)
        return (truth_end, end) if found == TRUTH else (setpoint_end, truth_end, end)

    def handle(self, msg: Message) -> None:
        kind = msg.get_type()
        if kind == "HIL_SENSOR":
            self._on_sensor_frame(bytes(msg.get_msgbuf()))
        elif kind == "HIL_GPS":
            self._on_gps(msg)
        elif kind == "SET_POSITION_TARGET_LOCAL_NED":
            if msg.target_system == self.config.system_id:
                self.offboard.receive(msg, self.now_us)
        elif kind == "ODOMETRY":
            self.truth = self.odometry.state(bytes(msg.get_msgbuf()))
        elif kind == "HIL_STATE_QUATERNION":
            self.truth = self._truth_from_ground_truth(codec.read_hil_state_quaternion(msg))
        elif kind in ("COMMAND_LONG", "COMMAND_INT"):
            self._on_command(msg)
        elif kind in ("PARAM_REQUEST_LIST", "PARAM_REQUEST_READ", "PARAM_SET"):
            self.param_server.handle(msg)
        elif kind in MISSION_MESSAGES:
            self.missions.handle(msg)
        elif kind == "HEARTBEAT":
            self.health.on_heartbeat(msg, self.now_us)
        elif kind == "MANUAL_CONTROL":
            if msg.target in (0, self.config.system_id):
                self.health.manual.receive(msg, self.now_us)
        elif kind == "BATTERY_STATUS":
            self.health.on_battery(msg)

    # --- the control step ---------------------------------------------------------------------------------
    def _on_sensor_frame(self, frame: bytes) -> None:
        estimator = self.estimator
        estimate = estimator.on_sensor_frame(frame)
        self.last_sensor_wall = self.clock()
        t_us = estimator.t_us
        assert t_us is not None
        dt = 0.0 if self.last_sensor_t_us is None else (t_us - self.last_sensor_t_us) * 1e-6
        self.last_sensor_t_us = t_us
        if self.boot_us is None:
            self.boot_us = t_us
        motors = self.motors_stopped
        state = self._state_of(estimate)
        if self.landed_at_us is not None:
            self._disarm_after_landing(t_us)
        if t_us >= self.navigator.next_tick_us:
            self._tick(state, t_us)
        if self.armed and state is not None and 0.0 < dt < 0.1 and self.landed_at_us is None:
            motors = self.control(state, dt, t_us)
        # Telemetry and heartbeat go out before the reply and on the simulation clock, like PX4 SITL's
        # streams: in lockstep the bench then sees each step's messages with that step's reply.
        self.telemetry.step(t_us, state, motors)

    def _tick(self, state: VehicleState | None, t_us: int) -> None:
        """The navigator's rate: mode logic, failsafes, home, the ground station's streams."""
        self.navigator.next_tick_us = t_us + NAVIGATOR_PERIOD_US
        self.health.tick(t_us)
        if state is not None:
            if self.armed:
                self.follow_sticks()
                self.navigator.tick(state, t_us)
            elif self.home is None and self.position_ok():
                self.set_home(state)
        self.failsafes.tick(t_us)
        self.telemetry.ground_station(t_us, state)

    def _on_gps(self, msg: Message) -> None:
        if self.last_sensor_t_us is None:
            return
        fix = codec.read_hil_gps(msg)
        self.estimator.on_gps(fix, self.last_sensor_t_us)
        self.last_fix, self.last_fix_us = fix, self.last_sensor_t_us
        self.health.on_fix(fix, self.last_sensor_t_us)

    def _state(self) -> VehicleState | None:
        return self._state_of(estimate_of(self.estimator.x))

    def _state_of(self, estimate: np.ndarray) -> VehicleState | None:
        """The state flown on, given the estimator's latest estimate (`estimate_values`'s array)."""
        if self.config.state_source == "truth":
            return self.truth
        if not self.estimator.aligned:
            return None
        return VehicleState(estimate[0:3], estimate[3:6], estimate[10:13], estimate[13:16])

    def _truth_from_ground_truth(self, t: codec.GroundTruth) -> VehicleState:
        """HIL_STATE_QUATERNION about the first sample's lat/lon (the origin a first fix would set)."""
        if self.estimator.origin is None:
            self.estimator.origin = LocalFrame(t.lat_deg, t.lon_deg, t.alt_msl_m)
        pos = np.array(self.estimator.origin.to_ned(t.lat_deg, t.lon_deg, t.alt_msl_m))
        return VehicleState(pos, np.array(t.vel_ned), quat_to_euler(np.array(t.q_wxyz)), np.array(t.rates_frd))

    # --- what the commander and navigator read -------------------------------------------------------------
    def settled(self) -> bool:
        """The arming check of the state the flight code flies on."""
        return self.truth is not None if self.config.state_source == "truth" else self.estimator.ready()

    def position_ok(self) -> bool:
        """A position to fly on: settled, and (on the estimator) aided by GPS within EKF2_NOAID_TOUT."""
        return self.settled() and (self.config.state_source == "truth" or not self.health.position_lost)

    def armable(self) -> bool:
        """Whether arming in the current mode would pass now (SYS_STATUS's PREARM_CHECK)."""
        return self.settled() and self.commander.can_arm()

    def manual_control_fresh(self) -> bool:
        """Stick input from a ground station within COM_RC_LOSS_T."""
        return self.health.manual_control_fresh(self.now_us)

    def manual_control_lost(self) -> bool:
        return self.health.manual_control_lost(self.now_us)

    @property
    def gcs_lost(self) -> bool:
        return self.health.gcs_lost

    @property
    def battery_warning(self) -> str:
        return self.health.battery_warning

    def local_frame(self) -> LocalFrame | None:
        return self.estimator.origin

    @property
    def landed_state(self) -> int:
        """EXTENDED_SYS_STATE.landed_state: on the ground until take-off and again once landed."""
        if not self.airborne:
            return MAV_LANDED_STATE_ON_GROUND
        if self.navigator.descending:
            return MAV_LANDED_STATE_LANDING
        return MAV_LANDED_STATE_TAKEOFF if self.navigator.taking_off else MAV_LANDED_STATE_IN_AIR

    # --- messages in and out -------------------------------------------------------------------------------
    def _on_command(self, msg: Message) -> None:
        if msg.target_system not in (0, self.config.system_id) or msg.target_component not in (0, 1):
            return
        command = Command.from_message(msg)
        result = self.commander.handle(command)
        if result == MAV_RESULT_UNSUPPORTED:
            result = self._link_command(command)
        self.link.send("COMMAND_ACK", command=msg.command, result=result, progress=0, result_param2=0,
                       target_system=msg.get_srcSystem(), target_component=msg.get_srcComponent())

    def _link_command(self, command: Command) -> int:
        """What PX4's MAVLink module answers itself: message requests and intervals."""
        if command.command == MAV_CMD_SET_MESSAGE_INTERVAL:
            return MAV_RESULT_ACCEPTED
        if command.command == MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES:
            return self._send_message(MAVLINK_MSG_ID_AUTOPILOT_VERSION)
        if command.command == MAV_CMD_GET_HOME_POSITION:
            return self._send_message(MAVLINK_MSG_ID_HOME_POSITION)
        if command.command == MAV_CMD_REQUEST_MESSAGE:
            return self._send_message(int(command.params[0]))
        return MAV_RESULT_UNSUPPORTED

    def _send_message(self, msgid: int) -> int:
        """REQUEST_MESSAGE: ACCEPTED when the message went out, DENIED otherwise (PX4's answers)."""
        sent = True
        if msgid == MAVLINK_MSG_ID_AUTOPILOT_VERSION:
            self._autopilot_version()
        elif msgid == MAVLINK_MSG_ID_HOME_POSITION:
            sent = self.telemetry.send_home_position()
        elif msgid == MAVLINK_MSG_ID_SYS_STATUS:
            self.telemetry.send_sys_status(self.now_us)
        elif msgid == MAVLINK_MSG_ID_MISSION_CURRENT:
            self.missions.send_current()
        elif msgid == MAVLINK_MSG_ID_GPS_RAW_INT and self.last_fix is not None:
            self.telemetry.send_gps_raw_int()
        else:
            sent = False
        return MAV_RESULT_ACCEPTED if sent else MAV_RESULT_DENIED

    def _autopilot_version(self) -> None:
        self.link.send("AUTOPILOT_VERSION", capabilities=CAPABILITIES, flight_sw_version=FLIGHT_SW_VERSION,
                       middleware_sw_version=0, os_sw_version=0, board_version=0,
                       flight_custom_version=[0] * 8, middleware_custom_version=[0] * 8, os_custom_version=[0] * 8,
                       vendor_id=0, product_id=0, uid=self.config.system_id, uid2=[0] * 18)

    def _send(self, message: str, fields: dict) -> None:
        self.link.send_fields(message, fields)

    def status(self, severity: int, text: str) -> None:
        """STATUSTEXT; a text longer than 50 characters in chunks of one id (id 0: a text in one piece)."""
        chunks = text_chunks(text)
        text_id = 0
        if len(chunks) > 1:
            self._text_id = self._text_id % 0xFFFF + 1
            text_id = self._text_id
        for seq, chunk in enumerate(chunks):
            self.link.send("STATUSTEXT", severity=severity, text=chunk.ljust(STATUSTEXT_CHUNK, "\0"), id=text_id,
                           chunk_seq=seq)

    def _mission_changed(self) -> None:
        """A new mission, a cleared one, or a new current item: AUTO.MISSION flies on from it."""
        if self.armed and self.commander.mode is FlightMode.AUTO_MISSION:
            self.fly(FlightMode.AUTO_MISSION)
