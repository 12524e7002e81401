"""What the board streams, on the simulation clock (in lockstep the bench then sees each step's messages with that
step's reply): HEARTBEAT 1 Hz, EXTENDED_SYS_STATE 5 Hz, ATTITUDE, LOCAL_POSITION_NED, GLOBAL_POSITION_INT,
ATTITUDE_TARGET and DEBUG_FLOAT_ARRAY 50 Hz; and at the rates PX4 streams them on its ground-station link,
SYS_STATUS 1 Hz, GPS_RAW_INT 5 Hz, VFR_HUD 4 Hz, HOME_POSITION 0.5 Hz (and when it changes), MISSION_CURRENT 1 Hz.

SYS_STATUS says what MAVSDK's health checks read (telemetry_impl.cpp, process_sys_status): gyro, accelerometer,
magnetometer, barometer, GPS and the attitude/position estimate present, enabled and healthy while their data
flow, and MAV_SYS_STATUS_PREARM_CHECK healthy when arming in the current mode would pass, as PX4 sets it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from pymavlink.dialects.v20.common import (
    MAV_AUTOPILOT_PX4,
    MAV_STATE_ACTIVE,
    MAV_STATE_BOOT,
    MAV_STATE_CRITICAL,
    MAV_STATE_STANDBY,
    MAV_SYS_STATUS_AHRS,
    MAV_SYS_STATUS_PREARM_CHECK,
    MAV_SYS_STATUS_SENSOR_3D_ACCEL,
    MAV_SYS_STATUS_SENSOR_3D_GYRO,
    MAV_SYS_STATUS_SENSOR_3D_MAG,
    MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE,
    MAV_SYS_STATUS_SENSOR_BATTERY,
    MAV_SYS_STATUS_SENSOR_GPS,
    MAV_SYS_STATUS_SENSOR_RC_RECEIVER,
    MAV_TYPE_HEXAROTOR,
    MAV_TYPE_OCTOROTOR,
    MAV_TYPE_QUADROTOR,
)

from firmware_interface import hil_codec as codec
from firmware_interface.emulator import reply_frames
from firmware_interface.emulator.commander import base_mode_flags
from firmware_interface.emulator.control import VehicleState
from firmware_interface.emulator.control.base import internals_in_order
from firmware_interface.emulator.geometry import euler_to_quat
from firmware_interface.emulator.reply_frames import ReplyBuffers, pack_reply

if TYPE_CHECKING:
    from firmware_interface.emulator.config import NominalVehicle
    from firmware_interface.emulator.firmware import EmulatedBoard

HEARTBEAT_PERIOD_US = 1_000_000
TELEMETRY_PERIOD_US = 20_000  # ATTITUDE, LOCAL_POSITION_NED, ATTITUDE_TARGET, DEBUG_FLOAT_ARRAY at 50 Hz
EXTENDED_SYS_STATE_PERIOD_US = 200_000  # 5 Hz, PX4's rate on its onboard link
SENSORS = (MAV_SYS_STATUS_SENSOR_3D_GYRO | MAV_SYS_STATUS_SENSOR_3D_ACCEL | MAV_SYS_STATUS_SENSOR_3D_MAG
           | MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE)
SENSOR_TIMEOUT_US = 1_000_000  # data older than this: the sensor counts as failed
GPS_TIMEOUT_US = 1_000_000


def vehicle_type(rotor_count: int) -> int:
    """HEARTBEAT's MAV_TYPE for a multirotor of this many rotors, as PX4 reports its airframe (MAV_TYPE param)."""
    return {6: MAV_TYPE_HEXAROTOR, 8: MAV_TYPE_OCTOROTOR}.get(rotor_count, MAV_TYPE_QUADROTOR)


def collective_fraction(thrust_n: float, vehicle: NominalVehicle) -> float:
    """The collective thrust as a share of what all the vehicle's rotors give at full command, in [0, 1]."""
    return min(max(thrust_n / (len(vehicle.rotors) * vehicle.thrust_max), 0.0), 1.0)


@dataclass
class Schedule:
    """A stream's period and when it is next due (µs of simulated time)."""

    period_us: int
    next_us: int = 0

    def due(self, t_us: int) -> bool:
        if t_us < self.next_us:
            return False
        self.next_us = t_us + self.period_us
        return True


class Telemetry:
    def __init__(self, board: EmulatedBoard) -> None:
        self.board = board
        self.last_heartbeat_us = -HEARTBEAT_PERIOD_US
        self.last_extended_state_us = -EXTENDED_SYS_STATE_PERIOD_US
        self.last_telemetry_us = -TELEMETRY_PERIOD_US
        self.sys_status, self.gps_raw = Schedule(1_000_000), Schedule(200_000)
        self.vfr_hud, self.home = Schedule(250_000), Schedule(2_000_000)
        self.reply = ReplyBuffers(board.controller.name)

    # --- every sensor step -------------------------------------------------------------------------------
    def step(self, t_us: int, state: VehicleState | None, motors: np.ndarray) -> None:
        """What the board sends after a HIL_SENSOR: the streams due, then HIL_ACTUATOR_CONTROLS with `motors`."""
        board = self.board
        if t_us - self.last_heartbeat_us >= HEARTBEAT_PERIOD_US:
            self.last_heartbeat_us = t_us
            self.heartbeat()
        if t_us - self.last_extended_state_us >= EXTENDED_SYS_STATE_PERIOD_US:
            self.last_extended_state_us = t_us
            board.link.send("EXTENDED_SYS_STATE", vtol_state=0, landed_state=board.landed_state)
        reply, link = self.reply, board.link
        flags = (reply_frames.ARMED if board.armed else 0) | (reply_frames.LOCKSTEP if board.config.lockstep else 0)
        if t_us - self.last_telemetry_us >= TELEMETRY_PERIOD_US and state is not None:
            self.last_telemetry_us = t_us
            flags |= reply_frames.STATE_STREAMS | self._stream_values()
            pos_ned, vel_ned, eta, rates_frd = state.pos_ned, state.vel_ned, state.eta, state.rates_frd
        else:
            pos_ned = vel_ned = eta = rates_frd = reply.unused
        link.encoder.numbering_into(reply.link)
        count = pack_reply(reply.frames, reply.ends, reply.link, flags, t_us, (t_us - (board.boot_us or t_us)) // 1000,
                           pos_ned, vel_ned, eta, rates_frd, reply.origin, reply.home_d, reply.eta_cmd,
                           reply.thrust, reply.debug, reply.debug_name, motors)
        link.send_frames(reply.frames, reply.ends, count)

    def heartbeat(self) -> None:
        board = self.board
        mode = board.commander.mode
        base_mode = (codec.MODE_FLAG_CUSTOM | codec.MODE_FLAG_HIL | (codec.MODE_FLAG_ARMED if board.armed else 0)
                     | base_mode_flags(mode))
        if board.armed:
            status = MAV_STATE_CRITICAL if board.failsafes.active else MAV_STATE_ACTIVE
        else:
            status = MAV_STATE_STANDBY if board.settled() else MAV_STATE_BOOT
        board.link.send("HEARTBEAT", type=vehicle_type(len(board.config.vehicle.rotors)), autopilot=MAV_AUTOPILOT_PX4,
                        base_mode=base_mode, custom_mode=int(mode), system_status=status, mavlink_version=3)

    def _stream_values(self) -> int:
        """The 50 Hz streams' values besides the state into the reply's buffers; returns which of them go out."""
        board, reply, flags = self.board, self.reply, 0
        origin = board.local_frame()
        if origin is not None:  # GLOBAL_POSITION_INT: what a ground station draws on its map (PX4 streams it too)
            flags |= reply_frames.GLOBAL_POSITION
            reply.origin[:] = origin.constants
            reply.home_d = float(board.home[2]) if board.home is not None else math.nan
        out = board.last_control
        if out is not None and board.armed:  # ATTITUDE_TARGET and DEBUG_FLOAT_ARRAY
            flags |= reply_frames.CONTROL_STREAMS
            reply.eta_cmd[:] = out.eta_cmd
            reply.thrust = collective_fraction(out.thrust_n, board.config.vehicle)
            keys = board.controller.internal_keys
            reply.debug[:len(keys)] = internals_in_order(out.internals, keys)
        return flags

    # --- at the navigator's rate: the ground station's streams ------------------------------------------
    def ground_station(self, t_us: int, state: VehicleState | None) -> None:
        board = self.board
        if self.sys_status.due(t_us):
            self.send_sys_status(t_us)
        if self.gps_raw.due(t_us) and board.last_fix is not None:
            self.send_gps_raw_int()
        if self.vfr_hud.due(t_us) and state is not None:
            self._vfr_hud(state)
        if self.home.due(t_us):
            self.send_home_position()
        board.missions.stream(t_us)

    def send_sys_status(self, t_us: int) -> None:
        board = self.board
        sensors = SENSORS if board.last_sensor_t_us is not None and \
            t_us - board.last_sensor_t_us < SENSOR_TIMEOUT_US else 0
        fix = board.last_fix
        gps = MAV_SYS_STATUS_SENSOR_GPS if fix is not None and fix.fix_type >= 3 and \
            t_us - board.last_fix_us < GPS_TIMEOUT_US else 0
        estimate = MAV_SYS_STATUS_AHRS if board.position_ok() else 0
        present = SENSORS | MAV_SYS_STATUS_SENSOR_GPS | MAV_SYS_STATUS_AHRS
        health = sensors | gps | estimate | (MAV_SYS_STATUS_PREARM_CHECK if board.armable() else 0)
        if board.manual_control_fresh():
            present |= MAV_SYS_STATUS_SENSOR_RC_RECEIVER
            health |= MAV_SYS_STATUS_SENSOR_RC_RECEIVER
        if board.health.battery is not None:
            present |= MAV_SYS_STATUS_SENSOR_BATTERY
            health |= 0 if board.battery_warning else MAV_SYS_STATUS_SENSOR_BATTERY
        millivolts, centiamps, percent = board.health.battery_mv_ca_percent()
        board.link.send("SYS_STATUS", onboard_control_sensors_present=present,
                        onboard_control_sensors_enabled=present, onboard_control_sensors_health=health, load=0,
                        voltage_battery=millivolts, current_battery=centiamps, drop_rate_comm=0, errors_comm=0,
                        errors_count1=0, errors_count2=0, errors_count3=0, errors_count4=0, battery_remaining=percent,
                        onboard_control_sensors_present_extended=0, onboard_control_sensors_enabled_extended=0,
                        onboard_control_sensors_health_extended=0)

    def send_gps_raw_int(self) -> None:
        fix = self.board.last_fix
        assert fix is not None
        north, east, _ = fix.vel_ned
        speed = math.hypot(north, east)
        self.board.link.send(
            "GPS_RAW_INT", time_usec=fix.t_us, lat=round(fix.lat_deg * 1e7), lon=round(fix.lon_deg * 1e7),
            alt=round(fix.alt_msl_m * 1000), eph=min(round(fix.eph_m * 100), 0xFFFF),
            epv=min(round(fix.epv_m * 100), 0xFFFF), vel=min(round(speed * 100), 0xFFFE),
            cog=round(math.degrees(math.atan2(east, north)) % 360 * 100), fix_type=fix.fix_type,
            satellites_visible=fix.satellites, alt_ellipsoid=0, h_acc=round(fix.eph_m * 1000),
            v_acc=round(fix.epv_m * 1000), vel_acc=0, hdg_acc=0, yaw=0)

    def _vfr_hud(self, state: VehicleState) -> None:
        board = self.board
        vel = state.vel_ned
        speed = math.hypot(float(vel[0]), float(vel[1]))
        origin = board.local_frame()
        altitude = origin.alt0_m - float(state.pos_ned[2]) if origin is not None else -float(state.pos_ned[2])
        out = board.last_control
        throttle = 0 if out is None or not board.armed else round(
            100 * collective_fraction(out.thrust_n, board.config.vehicle))
        board.link.send("VFR_HUD", airspeed=speed, groundspeed=speed, alt=altitude, climb=-float(vel[2]),
                        heading=round(math.degrees(float(state.eta[2])) % 360), throttle=throttle)

    def send_home_position(self) -> bool:
        """HOME_POSITION, once home is set; False before."""
        board = self.board
        home, origin = board.home, board.local_frame()
        if home is None or origin is None:
            return False
        lat, lon, alt = origin.to_geodetic(float(home[0]), float(home[1]), float(home[2]))
        q = euler_to_quat(0.0, 0.0, board.home_yaw)
        board.link.send("HOME_POSITION", latitude=round(lat * 1e7), longitude=round(lon * 1e7),
                        altitude=round(alt * 1000), x=float(home[0]), y=float(home[1]), z=float(home[2]),
                        q=[float(c) for c in q], approach_x=0.0, approach_y=0.0, approach_z=0.0,
                        time_usec=board.now_us)
        return True
