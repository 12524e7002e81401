"""The emulated flight controller: PX4's HIL protocol on one side, the paper's controllers inside.

Like PX4 with SYS_HITL=1 it sends a 1 Hz HEARTBEAT (autopilot PX4, quadrotor, HIL_ENABLED), takes
HIL_SENSOR / HIL_GPS (and, as truth when configured, ODOMETRY in the local frame at float precision, or
PX4 SITL's HIL_STATE_QUATERNION, whose integer lat/lon, mm and cm/s quantise it), answers COMMAND_LONG
with COMMAND_ACK, follows SET_POSITION_TARGET_LOCAL_NED in offboard mode, and answers each
HIL_SENSOR with exactly one HIL_ACTUATOR_CONTROLS (lockstep flag set, time_usec echoed, as PX4
SITL does). It knows only MAVLink bytes and its own configuration, never the plant.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import numpy as np
from pymavlink.dialects.v20.common import (
    MAV_AUTOPILOT_PX4,
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_CMD_DO_SET_MODE,
    MAV_CMD_NAV_LAND,
    MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES,
    MAV_CMD_REQUEST_MESSAGE,
    MAV_CMD_SET_MESSAGE_INTERVAL,
    MAV_LANDED_STATE_IN_AIR,
    MAV_LANDED_STATE_LANDING,
    MAV_LANDED_STATE_ON_GROUND,
    MAV_PARAM_TYPE_REAL32,
    MAV_PROTOCOL_CAPABILITY_COMMAND_INT,
    MAV_PROTOCOL_CAPABILITY_MAVLINK2,
    MAV_PROTOCOL_CAPABILITY_MISSION_INT,
    MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT,
    MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_DENIED,
    MAV_RESULT_TEMPORARILY_REJECTED,
    MAV_RESULT_UNSUPPORTED,
    MAV_SEVERITY_CRITICAL,
    MAV_SEVERITY_INFO,
    MAV_STATE_ACTIVE,
    MAV_STATE_BOOT,
    MAV_STATE_STANDBY,
    MAV_TYPE_QUADROTOR,
    MAVLINK_MSG_ID_AUTOPILOT_VERSION,
)

from firmware_interface import hil_codec as codec
from firmware_interface.emulator.config import EmulatorConfig
from firmware_interface.emulator.control import ControlOutput, Setpoint, VehicleState
from firmware_interface.emulator.control.registry import DEBUG_NAME_LENGTH, make_controller, wire_name
from firmware_interface.emulator.estimator import Estimator
from firmware_interface.emulator.geometry import euler_to_quat, quat_to_euler
from firmware_interface.emulator.mixer import Mixer
from firmware_interface.emulator.params import Parameter, parameter_table
from firmware_interface.geodesy import LocalFrame
from firmware_interface.link import Link, LinkLost, Message
from firmware_interface.px4_modes import (
    FORCE_DISARM_MAGIC,
    PX4_AUTO_SUB_MODE_LAND,
    PX4_MAIN_MODE_AUTO,
    PX4_MAIN_MODE_OFFBOARD,
    PX4_MAIN_MODE_POSCTL,
    custom_mode,
)

# what a GCS may use
CAPABILITIES = (MAV_PROTOCOL_CAPABILITY_MAVLINK2 | MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
                | MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED | MAV_PROTOCOL_CAPABILITY_COMMAND_INT
                | MAV_PROTOCOL_CAPABILITY_MISSION_INT)
FLIGHT_SW_VERSION = (0 << 24) | (1 << 16) | (0 << 8) | 255  # hil-bench emulator 0.1.0, release
HEARTBEAT_PERIOD_US = 1_000_000
TELEMETRY_PERIOD_US = 20_000  # ATTITUDE, LOCAL_POSITION_NED, ATTITUDE_TARGET, DEBUG_FLOAT_ARRAY at 50 Hz
EXTENDED_SYS_STATE_PERIOD_US = 200_000  # 5 Hz, PX4's rate on its onboard link
LANDED_CLEARANCE_M = 0.3  # adaptation and integrators wait until the vehicle has left the ground
# PX4's land mode and multicopter land detector, in their default settings: descend at MPC_LAND_SPEED;
# landed once vertical speed < LNDMC_Z_VEL_MAX, horizontal < LNDMC_XY_VEL_MAX and thrust low for
# LNDMC_TRIG_TIME; disarm COM_DISARM_LAND after that.
LAND_SPEED_M_S = 0.7  # the default of MPC_LAND_SPEED, settable like it
LAND_Z_VEL_MAX_M_S = 0.25
LAND_XY_VEL_MAX_M_S = 1.5
LAND_LOW_THRUST_FRACTION = 0.6  # of the hover thrust estimate (PX4's ground-contact limit with one)
LAND_TRIGGER_S = 1.0
DISARM_AFTER_LAND_S = 2.0


class EmulatedBoard:
    def __init__(self, link: Link, config: EmulatorConfig, clock: Callable[[], float] = time.monotonic) -> None:
        self.link = link
        self.config = config
        self.clock = clock
        self.link.encoder.system_id = config.system_id
        self.link.encoder.component_id = 1
        self.controller = make_controller(config)
        self.mixer = Mixer(config.vehicle)
        self.estimator = Estimator(config.estimator, config.vehicle.g)
        self.truth: VehicleState | None = None  # the latest true state received (state_source truth)
        self.armed = False
        self.offboard = False
        self.setpoint: Setpoint | None = None
        self.hold: Setpoint | None = None
        self.takeoff_d: float | None = None
        self.airborne = False
        self.landing = False  # in land mode (MAV_CMD_NAV_LAND)
        self.land_evidence_s = 0.0  # how long the land detector's conditions have held
        self.landed_at_us: int | None = None
        self.hover_thrust_n = 0.0
        self.last_extended_state_us = -EXTENDED_SYS_STATE_PERIOD_US
        self.last_sensor_t_us: int | None = None
        self.last_sensor_wall = clock()
        self.last_telemetry_us = -TELEMETRY_PERIOD_US
        self.last_heartbeat = -1e9
        self.last_heartbeat_us = -HEARTBEAT_PERIOD_US
        self.boot_us: int | None = None
        self.last_output: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0)
        self.last_control: ControlOutput | None = None
        self.stop_reason = ""
        self.land_speed_m_s = LAND_SPEED_M_S
        self.parameters: list[Parameter] = parameter_table(self)

    # --- main loop ----------------------------------------------------------------
    def run(self, should_stop: Callable[[], bool] = lambda: False) -> str:
        """Serve the link until it is lost or `should_stop()`; returns why it stopped."""
        try:
            while not should_stop():
                self._housekeeping()
                messages = self.link.receive(0.05)
                # everything answered to one read leaves in one write: the bench wakes once a step, for the
                # reply with that step's telemetry, instead of once for each message
                self.link.begin_batch()
                try:
                    for msg in messages:
                        self.handle(msg)
                finally:
                    self.link.flush()
        except LinkLost as exc:
            self.stop_reason = f"link lost: {exc.reason}"
            return self.stop_reason
        self.stop_reason = "stopped"
        return self.stop_reason

    def _housekeeping(self) -> None:
        now = self.clock()
        if self.last_sensor_t_us is None and now - self.last_heartbeat >= 1.0:  # no simulation clock yet
            self._heartbeat()
            self.last_heartbeat = now
        if self.armed and now - self.last_sensor_wall > self.config.failsafe_s:
            self._disarm()
            self._status(MAV_SEVERITY_CRITICAL, f"Failsafe: no HIL_SENSOR for {self.config.failsafe_s:g} s, disarming")

    def handle(self, msg: Message) -> None:
        kind = msg.get_type()
        if kind == "HIL_SENSOR":
            self._on_sensor(msg)
        elif kind == "HIL_GPS":
            if self.last_sensor_t_us is not None:
                self.estimator.on_gps(codec.read_hil_gps(msg), self.last_sensor_t_us)
        elif kind == "ODOMETRY":
            self.truth = self._truth_from_odometry(codec.read_odometry(msg))
        elif kind == "HIL_STATE_QUATERNION":
            self.truth = self._truth_from_ground_truth(codec.read_hil_state_quaternion(msg))
        elif kind == "COMMAND_LONG":
            self._on_command(msg)
        elif kind in ("PARAM_REQUEST_LIST", "PARAM_REQUEST_READ", "PARAM_SET"):
            self._on_param(msg)
        elif kind == "MISSION_REQUEST_LIST":  # an empty mission: this board flies offboard setpoints
            self.link.send("MISSION_COUNT", target_system=msg.get_srcSystem(), target_component=msg.get_srcComponent(),
                           count=0, mission_type=msg.mission_type, opaque_id=0)
        elif kind == "SET_POSITION_TARGET_LOCAL_NED":
            self.setpoint = Setpoint(np.array((msg.x, msg.y, msg.z)), np.array((msg.vx, msg.vy, msg.vz)),
                                     np.array((msg.afx, msg.afy, msg.afz)), msg.yaw)

    # --- the control step ---------------------------------------------------------
    def _on_sensor(self, msg: Message) -> None:
        readings = codec.read_hil_sensor(msg)
        self.last_sensor_wall = self.clock()
        dt = 0.0 if self.last_sensor_t_us is None else (readings.t_us - self.last_sensor_t_us) * 1e-6
        self.last_sensor_t_us = readings.t_us
        if self.boot_us is None:
            self.boot_us = readings.t_us
        self.estimator.on_sensors(readings)
        motors: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0)
        state = self._state()
        if self.landed_at_us is not None and readings.t_us - self.landed_at_us >= DISARM_AFTER_LAND_S * 1e6:
            self.landed_at_us = None
            self._disarm()
            self._status(MAV_SEVERITY_INFO, "Disarmed by landing")
        if self.armed and state is not None and 0.0 < dt < 0.1 and self.landed_at_us is None:
            motors = self._control(state, dt)
            if self.landing:
                self._detect_landing(state, dt, readings.t_us)
        self.last_output = motors
        # Telemetry and heartbeat go out before the reply and on the simulation clock, like PX4 SITL's
        # streams: in lockstep the bench then sees each step's messages with that step's reply.
        if readings.t_us - self.last_heartbeat_us >= HEARTBEAT_PERIOD_US:
            self.last_heartbeat_us = readings.t_us
            self._heartbeat()
        if readings.t_us - self.last_extended_state_us >= EXTENDED_SYS_STATE_PERIOD_US:
            self.last_extended_state_us = readings.t_us
            self.link.send("EXTENDED_SYS_STATE", vtol_state=0, landed_state=self.landed_state)
        if readings.t_us - self.last_telemetry_us >= TELEMETRY_PERIOD_US and state is not None:
            self.last_telemetry_us = readings.t_us
            self._telemetry(readings.t_us, state)
        self.link.send_fields("HIL_ACTUATOR_CONTROLS", codec.hil_actuator_controls_fields(
            readings.t_us, motors, self.armed, lockstep=self.config.lockstep))

    def _state(self) -> VehicleState | None:
        if self.config.state_source == "truth":
            return self.truth
        if not self.estimator.aligned:
            return None
        e = self.estimator.estimate()
        return VehicleState(e.pos_ned, e.vel_ned, e.eta, e.rates_frd)

    @staticmethod
    def _truth_from_odometry(t: codec.LocalTruth) -> VehicleState:
        """ODOMETRY's float32 values as they are: position in the sender's local NED frame."""
        return VehicleState(np.array(t.pos_ned), np.array(t.vel_ned), quat_to_euler(np.array(t.q_wxyz)),
                            np.array(t.rates_frd))

    def _truth_from_ground_truth(self, t: codec.GroundTruth) -> VehicleState:
        """HIL_STATE_QUATERNION about the first sample's lat/lon (the origin a first fix would set)."""
        if self.estimator.origin is None:
            self.estimator.origin = LocalFrame(t.lat_deg, t.lon_deg, t.alt_msl_m)
        pos = np.array(self.estimator.origin.to_ned(t.lat_deg, t.lon_deg, t.alt_msl_m))
        return VehicleState(pos, np.array(t.vel_ned), quat_to_euler(np.array(t.q_wxyz)), np.array(t.rates_frd))

    def _control(self, state: VehicleState, dt: float) -> tuple[float, ...]:
        if self.takeoff_d is None:
            self.takeoff_d = float(state.pos_ned[2])
        self.airborne = self.airborne or state.pos_ned[2] < self.takeoff_d - LANDED_CLEARANCE_M
        if self.landing and self.hold is not None:
            self.hold.pos_ned[2] += self.land_speed_m_s * dt  # a descent the ground ends, as PX4's land mode
            setpoint = self.hold
        elif self.offboard and self.setpoint is not None:
            setpoint = self.setpoint
        else:
            if self.hold is None:
                self.hold = Setpoint(state.pos_ned.copy(), np.zeros(3), np.zeros(3), float(state.eta[2]))
            setpoint = self.hold
        # no adaptation while landing: pushing on the ground would read as a heavier vehicle
        out = self.controller.update(state, setpoint, dt, adapt=self.airborne and not self.landing)
        self.last_control = out
        return tuple(float(u) for u in self.mixer.commands(out.thrust_n, out.torque_frd))

    @property
    def landed_state(self) -> int:
        """EXTENDED_SYS_STATE.landed_state: on the ground until take-off and again once landed."""
        if not self.airborne:
            return MAV_LANDED_STATE_ON_GROUND
        return MAV_LANDED_STATE_LANDING if self.landing else MAV_LANDED_STATE_IN_AIR

    def _detect_landing(self, state: VehicleState, dt: float, t_us: int) -> None:
        out = self.last_control
        still = (abs(float(state.vel_ned[2])) < LAND_Z_VEL_MAX_M_S
                 and float(np.hypot(state.vel_ned[0], state.vel_ned[1])) < LAND_XY_VEL_MAX_M_S
                 and out is not None and out.thrust_n < LAND_LOW_THRUST_FRACTION * self.hover_thrust_n)
        self.land_evidence_s = self.land_evidence_s + dt if still else 0.0
        if self.land_evidence_s >= LAND_TRIGGER_S:
            self.landing = False
            self.airborne = False
            self.landed_at_us = t_us
            self._status(MAV_SEVERITY_INFO, "Landing detected")

    def _start_landing(self) -> int:
        state = self._state()
        if not self.armed or state is None:
            return MAV_RESULT_DENIED
        self.landing, self.offboard, self.land_evidence_s = True, False, 0.0
        # the thrust that holds the vehicle now is the hover thrust estimate (payload included), as PX4's
        # hover thrust estimator gives its land detector
        nominal_n = self.config.vehicle.mass * self.config.vehicle.g
        self.hover_thrust_n = self.last_control.thrust_n if self.last_control is not None else nominal_n
        self.hold = Setpoint(state.pos_ned.copy(), np.array((0.0, 0.0, self.land_speed_m_s)), np.zeros(3),
                             float(state.eta[2]))
        self._status(MAV_SEVERITY_INFO, "Landing at current position")
        return MAV_RESULT_ACCEPTED

    # --- commands -----------------------------------------------------------------
    def _on_command(self, msg: Message) -> None:
        if msg.target_system not in (0, self.config.system_id):
            return
        result = MAV_RESULT_UNSUPPORTED
        if msg.command == MAV_CMD_COMPONENT_ARM_DISARM:
            if msg.param1 == 1.0:
                result = self._arm()
            elif self.airborne and round(msg.param2) != FORCE_DISARM_MAGIC:
                self._status(MAV_SEVERITY_CRITICAL, "Disarming denied: not landed")
                result = MAV_RESULT_TEMPORARILY_REJECTED
            else:
                self._disarm()
                result = MAV_RESULT_ACCEPTED
        elif msg.command == MAV_CMD_NAV_LAND:
            result = self._start_landing()
        elif msg.command == MAV_CMD_DO_SET_MODE:
            wants_offboard = int(msg.param2) == PX4_MAIN_MODE_OFFBOARD
            if wants_offboard and self.setpoint is None:
                self._status(MAV_SEVERITY_CRITICAL, "Offboard refused: no setpoint stream")
                result = MAV_RESULT_DENIED
            else:
                self.offboard = wants_offboard
                result = MAV_RESULT_ACCEPTED
        elif msg.command == MAV_CMD_SET_MESSAGE_INTERVAL:
            result = MAV_RESULT_ACCEPTED
        elif msg.command == MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES or (
                msg.command == MAV_CMD_REQUEST_MESSAGE and int(msg.param1) == MAVLINK_MSG_ID_AUTOPILOT_VERSION):
            self._autopilot_version()
            result = MAV_RESULT_ACCEPTED
        self.link.send("COMMAND_ACK", command=msg.command, result=result, progress=0, result_param2=0,
                       target_system=msg.get_srcSystem(), target_component=msg.get_srcComponent())

    def _arm(self) -> int:
        ready = self.truth is not None if self.config.state_source == "truth" else self.estimator.ready()
        if not ready:
            self._status(MAV_SEVERITY_CRITICAL, "Arming denied: estimator not settled")
            return MAV_RESULT_DENIED
        if not self.armed:
            self.armed = True
            self.controller.reset()
            self.takeoff_d = None
            self.airborne = False
            self.hold = None
            self._status(MAV_SEVERITY_INFO, f"Armed ({self.controller.name})")
        return MAV_RESULT_ACCEPTED

    def _disarm(self) -> None:
        self.armed = False
        self.offboard = False
        self.landing = False
        self.landed_at_us = None

    def _on_param(self, msg: Message) -> None:
        """The MAVLink parameter protocol: every PARAM_VALUE carries its index and the count."""
        kind = msg.get_type()
        if kind == "PARAM_REQUEST_LIST":
            for index in range(len(self.parameters)):
                self._param_value(index)
            return
        name = msg.param_id.rstrip("\0") if isinstance(msg.param_id, str) else ""
        index = next((i for i, p in enumerate(self.parameters) if p.name == name), -1)
        if kind == "PARAM_REQUEST_READ" and index < 0 and 0 <= msg.param_index < len(self.parameters):
            index = msg.param_index
        if index < 0:
            return  # unknown: PX4 does not answer either
        parameter = self.parameters[index]
        if kind == "PARAM_SET" and parameter.set is not None:
            parameter.set(float(msg.param_value))
            self._status(MAV_SEVERITY_INFO, f"{parameter.name} set to {parameter.get():g}")
        self._param_value(index)  # for a read-only one, the unchanged value says it was not set

    def _param_value(self, index: int) -> None:
        parameter = self.parameters[index]
        self.link.send("PARAM_VALUE", param_id=parameter.name, param_value=parameter.get(),
                       param_type=MAV_PARAM_TYPE_REAL32, param_count=len(self.parameters), param_index=index)

    def _autopilot_version(self) -> None:
        self.link.send("AUTOPILOT_VERSION", capabilities=CAPABILITIES, flight_sw_version=FLIGHT_SW_VERSION,
                       middleware_sw_version=0, os_sw_version=0, board_version=0,
                       flight_custom_version=[0] * 8, middleware_custom_version=[0] * 8, os_custom_version=[0] * 8,
                       vendor_id=0, product_id=0, uid=self.config.system_id, uid2=[0] * 18)

    # --- messages out -------------------------------------------------------------
    def _heartbeat(self) -> None:
        base_mode = codec.MODE_FLAG_CUSTOM | codec.MODE_FLAG_HIL | (codec.MODE_FLAG_ARMED if self.armed else 0)
        if self.landing:
            mode = custom_mode(PX4_MAIN_MODE_AUTO, PX4_AUTO_SUB_MODE_LAND)
        else:
            mode = custom_mode(PX4_MAIN_MODE_OFFBOARD if self.offboard else PX4_MAIN_MODE_POSCTL)
        ready = self.truth is not None if self.config.state_source == "truth" else self.estimator.ready()
        status = MAV_STATE_ACTIVE if self.armed else (MAV_STATE_STANDBY if ready else MAV_STATE_BOOT)
        self.link.send("HEARTBEAT", type=MAV_TYPE_QUADROTOR, autopilot=MAV_AUTOPILOT_PX4, base_mode=base_mode,
                       custom_mode=mode, system_status=status, mavlink_version=3)

    def _status(self, severity: int, text: str) -> None:
        self.link.send("STATUSTEXT", severity=severity, text=text[:50].ljust(50, "\0"), id=0, chunk_seq=0)

    def _telemetry(self, t_us: int, state: VehicleState) -> None:
        boot_ms = (t_us - (self.boot_us or t_us)) // 1000
        roll, pitch, yaw = (float(a) for a in state.eta)
        p, q, r = (float(w) for w in state.rates_frd)
        self.link.send("ATTITUDE", time_boot_ms=boot_ms, roll=roll, pitch=pitch, yaw=yaw, rollspeed=p,
                       pitchspeed=q, yawspeed=r)
        pos, vel = state.pos_ned, state.vel_ned
        self.link.send("LOCAL_POSITION_NED", time_boot_ms=boot_ms, x=float(pos[0]), y=float(pos[1]), z=float(pos[2]),
                       vx=float(vel[0]), vy=float(vel[1]), vz=float(vel[2]))
        origin = self.estimator.origin
        if origin is not None:  # what a ground station draws on its map (PX4 streams it too)
            lat, lon, alt = origin.to_geodetic(float(pos[0]), float(pos[1]), float(pos[2]))
            self.link.send("GLOBAL_POSITION_INT", time_boot_ms=boot_ms, lat=round(lat * 1e7), lon=round(lon * 1e7),
                           alt=round(alt * 1000), relative_alt=round(-float(pos[2]) * 1000),
                           vx=round(float(vel[0]) * 100), vy=round(float(vel[1]) * 100), vz=round(float(vel[2]) * 100),
                           hdg=round(math.degrees(yaw) % 360 * 100))
        out = self.last_control
        if out is None or not self.armed:
            return
        q_cmd = euler_to_quat(*(float(a) for a in out.eta_cmd))
        thrust = min(max(out.thrust_n / (4 * self.config.vehicle.thrust_max), 0.0), 1.0)
        self.link.send("ATTITUDE_TARGET", time_boot_ms=boot_ms, type_mask=0, q=[float(c) for c in q_cmd],
                       body_roll_rate=0.0, body_pitch_rate=0.0, body_yaw_rate=0.0, thrust=thrust)
        values = [float(out.internals[k]) for k in self.controller.internal_keys]
        name = wire_name(self.controller.name).ljust(DEBUG_NAME_LENGTH, "\0")
        self.link.send("DEBUG_FLOAT_ARRAY", time_usec=t_us, name=name, array_id=1,
                       data=values + [0.0] * (58 - len(values)))
