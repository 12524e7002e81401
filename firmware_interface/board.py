"""A session with a flight controller board over a `Link`.

Heartbeats, the handshake, sensor frames out and actuator frames in with PX4 SITL's lockstep bookkeeping,
commands and parameters sent without waiting (their answers land in `report`), setpoints, and a watchdog
(`board_watchdog`). The same code talks to a Pixhawk, PX4 SITL and the emulator; `board_requests` has what the
bench asks and the waiting forms.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from pymavlink.dialects.v20 import common
from pymavlink.dialects.v20.common import (
    MAV_AUTOPILOT_INVALID,
    MAV_CMD_SET_MESSAGE_INTERVAL,
    MAV_PARAM_TYPE_INT32,
    MAV_PARAM_TYPE_REAL32,
    MAV_TYPE_GCS,
)

from firmware_interface import hil_codec as codec
from firmware_interface import hil_frames as frames
from firmware_interface.actuator_reply import ActuatorReader
from firmware_interface.board_dropped_reply import LOOK_SPAN_S
from firmware_interface.board_report import BoardInfo, BoardReport
from firmware_interface.board_requests import (
    BoardError,
    ParamSet,
    ProtocolMessage,
    Request,
    float_as_int32,
    int32_as_float,
)
from firmware_interface.board_starvation import CpuStarvation
from firmware_interface.board_watchdog import RUNNABLE_RECHECK_S, LinkWatchdog
from firmware_interface.link import Link, Message
from firmware_interface.link.faults import LinkFaults
from firmware_interface.statustext import StatusTextJoiner

HITL_HINT = "is SYS_HITL=1 set, the board rebooted, and the port not held by QGroundControl?"
BENCH_COMPONENT_ID = 51  # as jMAVSim: not a GCS, not the autopilot
# the mission protocol as a ground station takes part in it, and the mission's progress
MISSION_KINDS = ("MISSION_REQUEST", "MISSION_REQUEST_INT", "MISSION_ACK", "MISSION_CURRENT", "MISSION_ITEM_REACHED")
EVENT_MSG_ID = 410  # MAVLink's EVENT (the events protocol), newer than pymavlink's dialect
INBOX_KINDS = frozenset({"HEARTBEAT", "STATUSTEXT", "COMMAND_ACK", "ATTITUDE_TARGET", "DEBUG_FLOAT_ARRAY",
                         "LOCAL_POSITION_NED", "ATTITUDE", "EXTENDED_SYS_STATE", *MISSION_KINDS})
# What a session decodes; the board's other messages stay whole frames (for the tlog and a ground station).
DECODED_IDS = frozenset(getattr(common, f"MAVLINK_MSG_ID_{kind}")
                        for kind in (*INBOX_KINDS, "HIL_ACTUATOR_CONTROLS", "PARAM_VALUE"))
# Messages of MAVLink's protocols rather than telemetry streams: never asked to stop (PX4 would refuse).
PROTOCOL_IDS = frozenset({common.MAVLINK_MSG_ID_TIMESYNC, common.MAVLINK_MSG_ID_COMMAND_LONG,
                          common.MAVLINK_MSG_ID_COMMAND_INT, EVENT_MSG_ID})
STOP_STREAM = -1.0  # MAV_CMD_SET_MESSAGE_INTERVAL's param2 that stops a stream


@dataclass(frozen=True)
class LinkPolicy:
    """What a session may do with its board: the two ways a board on its own clock differs from a simulated one."""

    own_clock: bool  # the board keeps its own time (a Pixhawk, PX4's HITL path): never lockstep, never waited for
    takes_ground_truth: bool  # the true state may be sent (PX4 SITL logs it, the emulator may fly on it); a real
    # board's EKF2 would take HIL_STATE_QUATERNION over its own estimate


SIMULATED = LinkPolicy(own_clock=False, takes_ground_truth=True)  # PX4 SITL, the emulator: lockstep
ON_OWN_CLOCK = LinkPolicy(own_clock=True, takes_ground_truth=False)  # a Pixhawk, PX4's HITL rehearsal


class BoardSession:
    """One conversation with one board. Times are monotonic seconds unless named `_us`."""

    def __init__(self, link: Link, policy: LinkPolicy, heartbeat_period_s: float = 1.0,
                 watchdog_s: float = 1.0, free_run_wait_s: float = 0.01,
                 clock: Callable[[], float] = time.monotonic, reversible_motors: bool = False,
                 motor_count: int = 4) -> None:
        self.link = link
        self.policy = policy
        self.heartbeat_period_s = heartbeat_period_s
        self.watchdog = LinkWatchdog(watchdog_s, lockstep_board=not policy.own_clock)
        self.free_run_wait_s = free_run_wait_s
        self.actuator_reader = ActuatorReader(motor_count, reversible_motors)
        self.clock = clock
        self.report = BoardReport()
        self.inbox: list[Message] = []  # messages of `INBOX_KINDS` since the caller last drained it
        self.relay: list[bytes] | None = None  # when a list: the raw frames of every non-HIL message, for a GCS
        # True: ask the board to stop each telemetry stream it sends here that the bench does not read (only
        # where no ground station shares the link). PX4's onboard link streams ~400 messages a second.
        self.stop_unread_streams = False
        self.streams_stopped: list[int] = []  # the message ids asked to stop, in order
        self.lockstep = False  # true from the first HIL_ACTUATOR_CONTROLS on (SITL / emulator)
        self.wait_for_replies = True  # False: never wait for a reply, as with a real board (injected link faults)
        self.starvation: CpuStarvation | None = None  # on its own clock, a board process the bench runs here
        self.actuators: codec.ActuatorOutputs | None = None
        self._awaited_t_us: int | None = None  # lockstep: the sensor step whose reply we wait for
        self._truth_ahead: bytes | None = None  # a HIL_STATE_QUATERNION frame for the next step's write
        self._last_heartbeat_sent = -1e9
        self.ground_station_silent = False  # a ground-station loss: the bench's own GCS heartbeat is not sent
        self._texts = StatusTextJoiner()
        self._last_rx = clock()
        self.link.encoder.component_id = BENCH_COMPONENT_ID
        self.link.decoded_ids = DECODED_IDS
        self.link.whole_frame_reader = self._read_reply
        self.start_time = clock()

    # --- housekeeping -------------------------------------------------------------
    def service(self, now_s: float | None = None) -> None:
        """Send our heartbeat when due (1 Hz), as jMAVSim/Gazebo do; PX4 USB needs one to start MAVLink.

        It says MAV_TYPE_GCS because PX4 sends STATUSTEXT (arming denials, failsafes) only on a link on
        which a GCS has spoken. `now_s` is the simulation clock in lockstep, so that PX4 sees 1 Hz in its
        own time whatever the real-time factor (the wall clock otherwise).
        """
        now = self.clock() if now_s is None else now_s
        if self.ground_station_silent:
            return
        if now - self._last_heartbeat_sent >= self.heartbeat_period_s or now < self._last_heartbeat_sent:
            self.link.send("HEARTBEAT", type=MAV_TYPE_GCS, autopilot=MAV_AUTOPILOT_INVALID,
                           base_mode=0, custom_mode=0, system_status=0, mavlink_version=3)
            self._last_heartbeat_sent = now
            if self.stop_unread_streams and self.report.info is not None:
                self._stop_streams_seen()

    def _stop_streams_seen(self) -> None:
        """MAV_CMD_SET_MESSAGE_INTERVAL(id, -1) for every message seen on the link since the last call that
        the bench neither reads nor needs for a protocol: fewer messages for the board to send and for the
        bench to take in. Once per id; the ACKs arrive like any other."""
        unread = sorted(self.link.ids_seen - DECODED_IDS - PROTOCOL_IDS - set(self.streams_stopped))
        for msgid in unread:
            self.request(MAV_CMD_SET_MESSAGE_INTERVAL, (float(msgid), STOP_STREAM))
        self.streams_stopped += unread

    def take_inbox(self) -> list[Message]:
        """The messages of `INBOX_KINDS` since the last call, in arrival order."""
        messages, self.inbox = self.inbox, []
        return messages

    def relay_to_ground_stations(self) -> None:
        """From now on keep every non-HIL frame for `take_relayed` (a ground station is listening)."""
        self.relay = []

    def take_relayed(self) -> list[bytes]:
        """The frames kept for ground stations since the last call."""
        frames, self.relay = self.relay or [], [] if self.relay is not None else None
        return frames

    def inject_faults(self, faults: LinkFaults) -> None:
        """Frames cross `faults` on this link from now on. They act in wall-clock time (as a board's failsafe
        counts it), so replies are no longer waited for, and the watchdog allows the longest outage."""
        self.link.faults = faults
        self.wait_for_replies = False
        self.watchdog.watchdog_s += faults.longest_outage_s()

    def check_watchdog(self) -> bool:  # `LinkWatchdog.check` of the silence so far
        return self.watchdog.check(self.clock() - self._last_rx, self.link.name)

    def poll(self, timeout_s: float = 0.0) -> list[Message]:
        """Read and handle whatever arrives within `timeout_s`."""
        messages = self.link.receive(timeout_s)
        for msg in messages:
            self._handle(msg)
        if self.link.passthrough:  # valid frames the bench does not read: a GCS may
            self._last_rx = self.clock()
            if self.relay is not None:
                self.relay += self.link.passthrough
            self.link.passthrough = []
        return messages

    def _handle(self, msg: Message) -> None:
        self._last_rx = self.clock()
        kind = msg.get_type()
        info = self.report.info
        if info is not None and msg.get_srcSystem() != info.system_id and kind != "HEARTBEAT":
            return
        if self.relay is not None and not kind.startswith("HIL_"):
            self.relay.append(bytes(msg.get_msgbuf()))
        if kind == "HIL_ACTUATOR_CONTROLS":  # in `actuators`, never in the inbox or `report.latest`
            self._take_reply(self.actuator_reader.read(bytes(msg.get_msgbuf())))  # pymavlink's: a bytearray
            return
        if kind == "HEARTBEAT":
            self._handle_heartbeat(msg)
        elif kind == "COMMAND_ACK":
            self.report.acks[msg.command] = msg.result
        elif kind == "PARAM_VALUE":
            integer = msg.param_type == MAV_PARAM_TYPE_INT32
            self.report.params[msg.param_id] = float(float_as_int32(msg.param_value) if integer else msg.param_value)
        elif kind == "STATUSTEXT":
            text = self._texts.join(msg)
            if text is None:
                return  # more chunks to come
            msg.text = text
            self.report.status_texts.append((msg.severity, text))
        if kind in INBOX_KINDS:
            self.inbox.append(msg)
        self.report.latest[kind] = msg

    def _read_reply(self, data: bytes) -> tuple[int, ...]:
        """The link's reader of a read that is one whole HIL_ACTUATOR_CONTROLS frame of the board's: the lockstep
        reply, handled in one compiled call (`actuator_reply`). () leaves the read to the scanner."""
        outputs, info = self.actuator_reader.read(data), self.report.info
        if outputs is None or (info is not None and self.actuator_reader.system_id != info.system_id):
            return ()
        self._last_rx = self.clock()
        self._take_reply(outputs)
        return (len(data),)

    def _take_reply(self, outputs: codec.ActuatorOutputs | None) -> None:
        if outputs is None:
            return
        self.actuators = outputs
        if not self.policy.own_clock:
            self.lockstep = self.lockstep or outputs.lockstep
            self.watchdog.replied(outputs.t_us)
        if self._awaited_t_us is not None and outputs.t_us >= self._awaited_t_us:
            self._awaited_t_us = None

    def _handle_heartbeat(self, msg: Message) -> None:
        if msg.autopilot == MAV_AUTOPILOT_INVALID:  # another simulator or GCS, not the board
            return
        armed = bool(msg.base_mode & codec.MODE_FLAG_ARMED)
        self.report.info = BoardInfo(msg.get_srcSystem(), msg.get_srcComponent(), msg.autopilot, msg.type,
                                    bool(msg.base_mode & codec.MODE_FLAG_HIL), armed)
        self.report.armed = armed
        self.report.custom_mode = msg.custom_mode
        self.link.encoder.system_id = msg.get_srcSystem()  # adopt the board's system id, as jMAVSim does

    # --- handshake ----------------------------------------------------------------
    def wait_heartbeat(self, timeout_s: float = 5.0, hint: str = HITL_HINT,
                       still_starting: Callable[[], None] | None = None) -> BoardInfo:
        """Wait for the board's first heartbeat; `still_starting` may raise when the board's process died. A lockstep
        board then has as long for any silence until it has booted (`LinkWatchdog`)."""
        self.watchdog.start_timeout_s = timeout_s
        deadline = self.clock() + timeout_s
        while self.report.info is None:
            if self.clock() > deadline:
                raise BoardError(f"no heartbeat on {self.link.name} within {timeout_s:g} s ({self._what_arrived()})"
                                 f" — {hint}")
            if still_starting is not None:
                still_starting()
            self.service()
            self.poll(0.05)
        self._last_rx = self.clock()
        return self.report.info

    def _what_arrived(self) -> str:
        """What the line carried while we waited: nothing at all, bytes but no frame (a wrong baud rate
        shows as garbage), or frames but no autopilot heartbeat."""
        if self.link.bytes_in == 0:
            return "no bytes arrived at all"
        if self.link.scanner.frames_accepted == 0:
            return f"{self.link.bytes_in} bytes arrived but no MAVLink frame: a wrong baud rate?"
        return f"{self.link.scanner.frames_accepted} MAVLink frames arrived, none a heartbeat from an autopilot"

    # --- sensors and actuators ----------------------------------------------------
    def send_sensors(self, readings: codec.SensorReadings, gps: codec.GpsFix | None = None,
                     truth: codec.GroundTruth | codec.LocalTruth | None = None) -> None:
        row = codec.sensor_row(readings, gps)
        if gps is not None:
            self.link.send_frame(self.link.pack(frames.encode_hil_gps, row))
        if truth is not None:
            self.send_ground_truth(truth)
        self.link.send_frame(self.link.pack(frames.encode_hil_sensor, row))

    def send_ground_truth(self, truth: codec.GroundTruth | codec.LocalTruth) -> bool:
        """HIL_STATE_QUATERNION (a GroundTruth, what PX4 SITL reads) or ODOMETRY (a LocalTruth, float precision, the
        emulator's exact-state path) to SITL or the emulator; refused for a real board (it would override EKF2)."""
        if not self.policy.takes_ground_truth:
            return False
        self.link.send_frame(self._truth_frame(truth))
        return True

    def _truth_frame(self, truth: codec.GroundTruth | codec.LocalTruth) -> bytes:
        if isinstance(truth, codec.LocalTruth):
            return self.link.pack(frames.encode_odometry, truth.t_us, np.array(truth.pos_ned), np.array(truth.vel_ned),
                                  np.array(truth.q_wxyz), np.array(truth.rates_frd))
        return self.link.pack(frames.encode_hil_state_quaternion, truth.t_us, np.array(truth.q_wxyz),
                              np.array(truth.rates_frd), np.array((truth.lat_deg, truth.lon_deg, truth.alt_msl_m)),
                              np.array(truth.vel_ned), np.array(truth.specific_force_frd), truth.airspeed_m_s)

    def send_ground_truth_ahead(self, t_us: int, q_wxyz: np.ndarray, rates_frd: np.ndarray, lat_lon_alt: np.ndarray,
                                vel_ned: np.ndarray, specific_force_frd: np.ndarray, airspeed_m_s: float) -> None:
        """HIL_STATE_QUATERNION for PX4 SITL's log (`*_groundtruth`), packed from arrays while the board computes and
        written first in the next step's frame, where PX4's lockstep clock still reads this truth's time (in the
        step's own write it was a step early). Never for a real board."""
        if self.policy.takes_ground_truth:
            self._truth_ahead = self.link.pack(frames.encode_hil_state_quaternion, t_us, q_wxyz, rates_frd,
                                               lat_lon_alt, vel_ned, specific_force_frd, airspeed_m_s)

    def exchange(self, readings: codec.SensorReadings, gps: codec.GpsFix | None = None,
                 truth: codec.GroundTruth | codec.LocalTruth | None = None) -> codec.ActuatorOutputs | None:
        """One bench step: `send_step`, then `await_reply`."""
        self.send_step(readings, gps, truth)
        return self.await_reply()

    def send_step(self, readings: codec.SensorReadings, gps: codec.GpsFix | None = None,
                  truth: codec.GroundTruth | codec.LocalTruth | None = None) -> None:
        """Send this step's sensors; the reply to wait for is the one echoing `readings.t_us`."""
        self.begin_step(readings.t_us)
        self.send_sensors(readings, gps, truth)

    def begin_step(self, t_us: int) -> None:
        """What goes ahead of the sensor frames of the step at `t_us` (the truth built during the last step, our
        heartbeat when due); the reply to wait for is the one echoing `t_us`."""
        if self._truth_ahead is not None:  # first: it was numbered before anything else in this write
            self.link.send_frame(self._truth_ahead)
            self._truth_ahead = None
        self.service(t_us * 1e-6 if self.lockstep else None)
        self._awaited_t_us = t_us

    @property
    def waits_for_replies(self) -> bool:
        """False for a board on its own clock (a Pixhawk, or any board behind injected link faults)."""
        return not self.policy.own_clock and self.wait_for_replies

    def await_reply(self) -> codec.ActuatorOutputs | None:
        """The actuator outputs for the step just sent. PX4 SITL (and the emulator) echo the triggering HIL_SENSOR's
        time_usec in HIL_ACTUATOR_CONTROLS, so stale replies to earlier steps are skipped. Before lockstep starts
        (free-run) each step waits at most `free_run_wait_s` for a first reply, so no backlog of replies builds up;
        once a reply has started lockstep, an earlier step's too, the step's own is waited for as long as the
        watchdog allows (on a loaded machine the first replies can lag by more than the free-run wait), unless the
        board dropped it (`board_dropped_reply`). A board on its own clock is never waited for, but for a process of
        this machine while the machine starves it of CPU (`board_starvation`). BoardError when the watchdog expires.
        """
        if not self.waits_for_replies:
            self._awaited_t_us = None
            self.poll(0.0)
            if self.starvation is not None:
                self.starvation.wait_out(self.poll)
            self.check_watchdog()
            return self.actuators
        started, lockstep = self.clock(), self.lockstep
        deadline = started + (self.watchdog.limit_s if lockstep else self.free_run_wait_s)
        while self._awaited_t_us is not None:
            if self.lockstep and not lockstep:  # an earlier step's reply began lockstep: this one's reply will come
                lockstep = True
                deadline = started + self.watchdog.limit_s
            remaining = deadline - self.clock()
            if remaining <= 0:
                if self.check_watchdog():  # its process waits for a CPU: look again shortly
                    deadline = self.clock() + RUNNABLE_RECHECK_S
                    continue
                if lockstep:
                    raise BoardError(f"no HIL_ACTUATOR_CONTROLS within {self.watchdog.limit_s:.2f} s in lockstep")
                break
            self.poll(min(remaining, LOOK_SPAN_S))
            awaited = self._awaited_t_us
            if lockstep and awaited is not None and self.watchdog.reply_dropped(self.clock() - started, awaited):
                break
        self._awaited_t_us = None
        return self.actuators

    # --- commands -----------------------------------------------------------------
    def target(self) -> tuple[int, int]:
        info = self.report.info
        return (info.system_id, info.component_id) if info else (1, 1)

    def request(self, command: int, params: tuple[float, ...] = ()) -> None:
        """Send a COMMAND_LONG without waiting; its COMMAND_ACK lands in `report.acks` when it comes."""
        system, component = self.target()
        p = tuple(params) + (0.0,) * (7 - len(params))
        self.report.acks.pop(command, None)
        self.link.send("COMMAND_LONG", target_system=system, target_component=component, command=command,
                       confirmation=0, param1=p[0], param2=p[1], param3=p[2], param4=p[3], param5=p[4],
                       param6=p[5], param7=p[6])

    def set_param(self, name: str, value: float) -> None:
        """PARAM_SET without waiting: REAL32, or INT32 when `value` is a Python int (PX4 refuses a type that is not
        the parameter's); PX4 answers with PARAM_VALUE (see `report.params`)."""
        system, component = self.target()
        self.report.params.pop(name, None)
        wire, kind = (int32_as_float(value), MAV_PARAM_TYPE_INT32) if isinstance(value, int) else (
            float(value), MAV_PARAM_TYPE_REAL32)
        self.link.send("PARAM_SET", target_system=system, target_component=component, param_id=name,
                       param_value=wire, param_type=kind)

    def ask(self, ask: Request | ParamSet | ProtocolMessage) -> None:
        """Send a command, a parameter or a protocol's message without waiting for the answer."""
        if isinstance(ask, ParamSet):
            self.set_param(ask.name, ask.value)
        elif isinstance(ask, ProtocolMessage):
            system, component = self.target()
            self.link.send(ask.type, target_system=system, target_component=component, **dict(ask.fields))
        else:
            self.request(ask.command, ask.params)

    def send_setpoint(self, t_boot_ms: int, pos_ned: np.ndarray | codec.Vec3, vel_ned: np.ndarray | codec.Vec3,
                      acc_ned: np.ndarray | codec.Vec3, yaw_rad: float) -> None:
        """SET_POSITION_TARGET_LOCAL_NED: position, velocity, acceleration and yaw in the board's local NED."""
        vectors = (np.asarray(v, dtype=np.float64) for v in (pos_ned, vel_ned, acc_ned))
        self.link.send_frame(self.link.pack(frames.encode_setpoint, t_boot_ms & 0xFFFFFFFF, *self.target(),
                                            *vectors, float(yaw_rad)))
