"""The board's flight: arming and disarming, home, starting the mode the commander chose, the control step,
and PX4's land detector with its disarm.

PX4's land mode and multicopter land detector, in their default settings: descend at MPC_LAND_SPEED; landed
once vertical speed < LNDMC_Z_VEL_MAX, horizontal < LNDMC_XY_VEL_MAX and thrust low for LNDMC_TRIG_TIME;
disarm COM_DISARM_LAND after that.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
from pymavlink.dialects.v20.common import MAV_SEVERITY_INFO

from firmware_interface.emulator.control import Controller, ControlOutput, VehicleState
from firmware_interface.emulator.manual_control import StickReference
from firmware_interface.emulator.mission_run import MissionRun
from firmware_interface.emulator.mixer import Mixer
from firmware_interface.emulator.navigator import Navigator, state_setpoint
from firmware_interface.emulator.offboard import OffboardReference
from firmware_interface.emulator.return_run import ReturnRun
from firmware_interface.px4_modes import FlightMode

if TYPE_CHECKING:
    from firmware_interface.emulator.commander import Commander
    from firmware_interface.emulator.config import EmulatorConfig
    from firmware_interface.emulator.failsafe import Failsafes
    from firmware_interface.emulator.health import Health
    from firmware_interface.emulator.mission_protocol import MissionServer
    from firmware_interface.emulator.offboard import OffboardInput
    from firmware_interface.emulator.px4_params import Px4Values
    from firmware_interface.emulator.telemetry import Telemetry
    from firmware_interface.geodesy import LocalFrame

LANDED_CLEARANCE_M = 0.3  # adaptation and integrators wait until the vehicle has left the ground
LAND_Z_VEL_MAX_M_S = 0.25
LAND_XY_VEL_MAX_M_S = 1.5
LAND_LOW_THRUST_FRACTION = 0.6  # of the hover thrust estimate (PX4's ground-contact limit with one)
LAND_TRIGGER_S = 1.0
HOVER_THRUST_FILTER = 0.01  # per step: the hover thrust estimate follows the thrust flown level in ~0.4 s


class Flight:
    """Mixed into the board, which provides what is declared here."""

    config: EmulatorConfig
    controller: Controller
    mixer: Mixer
    params: Px4Values
    commander: Commander
    missions: MissionServer
    offboard: OffboardInput
    last_control: ControlOutput | None
    telemetry: Telemetry
    failsafes: Failsafes
    health: Health
    last_sensor_t_us: int | None
    status: Callable[[int, str], None]
    _state: Callable[[], VehicleState | None]
    local_frame: Callable[[], LocalFrame | None]
    manual_control_fresh: Callable[[], bool]

    def __init__(self) -> None:
        self.armed = False
        self.airborne = False
        self.takeoff_d: float | None = None  # the height the vehicle was armed at
        self.land_evidence_s = 0.0  # how long the land detector's conditions have held
        self.landed_at_us: int | None = None
        self.hover_thrust_n = 0.0
        self.home: np.ndarray | None = None  # local NED, set on the ground before arming and at arming (PX4)
        self.home_yaw = 0.0
        self.navigator = Navigator(self.params, self)

    @property
    def now_us(self) -> int:
        """Simulated time (µs) of the latest sensor frame; 0 before the first."""
        return self.last_sensor_t_us or 0

    def home_ned(self) -> np.ndarray | None:
        return self.home

    # --- arming --------------------------------------------------------------------------------------------
    def arm(self) -> None:
        self.armed = True
        self.failsafes.armed_changed()
        self.health.on_arm(self.now_us)
        self.controller.reset()
        self.takeoff_d = None
        self.airborne = False
        self.navigator.clear()
        state = self._state()
        if state is not None:
            self.set_home(state)
        self.status(MAV_SEVERITY_INFO, f"Armed ({self.controller.name})")
        self.fly(self.commander.mode)

    def disarm(self) -> None:
        self.armed = False
        self.landed_at_us = None
        self.navigator.clear()
        self.commander.reset()
        self.failsafes.armed_changed()

    def set_home(self, state: VehicleState) -> None:
        self.home, self.home_yaw = state.pos_ned.copy(), float(state.eta[2])
        self.telemetry.send_home_position()

    # --- the mode flown -----------------------------------------------------------------------------------
    def fly(self, mode: FlightMode, blind: bool = False) -> None:
        """Start flying `mode` from the last reference (armed); `blind`: AUTO.LAND without a position estimate
        (PX4's Descend)."""
        navigator, state, t_us = self.navigator, self._state(), self.now_us
        if state is None:
            return
        if navigator.last is None and self.airborne:
            navigator.last = state_setpoint(state)
        if blind:
            navigator.descend_blind(state)
        elif mode is FlightMode.AUTO_TAKEOFF:
            navigator.take_off(state, t_us)
        elif mode is FlightMode.AUTO_LAND:
            navigator.land_here(state, t_us)
        elif mode is FlightMode.AUTO_MISSION:
            MissionRun(navigator, self.missions, state, t_us)
        elif mode is FlightMode.AUTO_RTL and self.airborne:
            ReturnRun(navigator, state, t_us)
        elif mode is FlightMode.OFFBOARD:
            navigator.task = None
            if navigator.last is None:
                navigator.last = state_setpoint(state)
            navigator.reference = OffboardReference(self.offboard, navigator)
        else:  # POSCTL, MANUAL, AUTO.LOITER, and AUTO.RTL on the ground
            navigator.hold(t_us)

    def follow_sticks(self) -> None:
        """POSCTL and MANUAL fly the sticks once a ground station sends them (until then they hold)."""
        navigator = self.navigator
        if self.commander.mode not in (FlightMode.POSCTL, FlightMode.MANUAL) or self.commander.failsafe \
                or isinstance(navigator.reference, StickReference) or not self.manual_control_fresh():
            return
        state = navigator.state
        start = navigator.last if navigator.last is not None else (state_setpoint(state) if state else None)
        if start is not None:
            navigator.task = None
            navigator.reference = StickReference(self.health.manual, self.params, start, self.manual_control_fresh)

    def reposition(self, lat_deg: float, lon_deg: float, alt_amsl: float) -> None:
        """DO_REPOSITION in AUTO.LOITER: go there and hold (NaN: keep that coordinate)."""
        frame, last = self.local_frame(), self.navigator.last
        if frame is None or last is None or not self.airborne:
            return
        north, east, down = frame.to_ned(lat_deg, lon_deg, alt_amsl if math.isfinite(alt_amsl) else 0.0)
        target = np.array((north if math.isfinite(lat_deg) else last.pos_ned[0],
                           east if math.isfinite(lon_deg) else last.pos_ned[1],
                           down if math.isfinite(alt_amsl) else last.pos_ned[2]))
        self.navigator.move_to(target, self.now_us, None)

    def mode_completed(self, mode: FlightMode) -> None:
        """Take-off done, mission done: AUTO.LOITER, as PX4's commander switches, holding at the position setpoint
        (the take-off altitude, the last waypoint): the move there runs on and ends at rest."""
        if self.commander.mode is mode and not self.commander.failsafe:
            self.commander.reset(FlightMode.AUTO_LOITER)
            self.navigator.task = None

    def request_mode(self, mode: FlightMode) -> None:
        """A mission's RETURN_TO_LAUNCH item: the command PX4's navigator issues to its commander."""
        self.status(MAV_SEVERITY_INFO, "Returning to launch")
        self.commander.change_mode(mode)

    def descent_started(self) -> None:
        """The thrust that holds the vehicle now is the hover thrust estimate (payload included), as PX4's hover
        thrust estimator gives its land detector."""
        self.land_evidence_s = 0.0
        nominal_n = self.config.vehicle.mass * self.config.vehicle.g
        self.hover_thrust_n = self.last_control.thrust_n if self.last_control is not None else nominal_n

    # --- the control step ---------------------------------------------------------------------------------
    def control(self, state: VehicleState, dt: float, t_us: int) -> np.ndarray:
        """The rotors' commands (0..1) of this step."""
        if self.takeoff_d is None:
            self.takeoff_d = float(state.pos_ned[2])
        self.airborne = self.airborne or state.pos_ned[2] < self.takeoff_d - LANDED_CLEARANCE_M
        navigator = self.navigator
        setpoint = navigator.setpoint(state, t_us, dt)
        descending = navigator.descending
        # no adaptation while landing: pushing on the ground would read as a heavier vehicle
        out = self.controller.update(state, setpoint, dt, adapt=self.airborne and not descending)
        self.last_control = out
        motors = self.mixer.commands(out.thrust_n, out.torque_frd)
        if descending:
            self._detect_landing(state, dt, t_us)
        elif self.airborne:  # PX4's hover thrust estimate, for a descent that does not start in a land mode
            self.hover_thrust_n += HOVER_THRUST_FILTER * (out.thrust_n - self.hover_thrust_n)
        return motors

    def _detect_landing(self, state: VehicleState, dt: float, t_us: int) -> None:
        out = self.last_control
        # without a position estimate (a blind descent) the horizontal velocity is not known and not judged, as
        # PX4's MulticopterLandDetector skips it when its local position's v_xy is invalid
        still = (abs(float(state.vel_ned[2])) < LAND_Z_VEL_MAX_M_S
                 and (self.navigator.blind or float(np.hypot(state.vel_ned[0], state.vel_ned[1])) < LAND_XY_VEL_MAX_M_S)
                 and out is not None and out.thrust_n < LAND_LOW_THRUST_FRACTION * self.hover_thrust_n)
        self.land_evidence_s = self.land_evidence_s + dt if still else 0.0
        if self.land_evidence_s >= LAND_TRIGGER_S:
            self.airborne = False
            self.landed_at_us = t_us
            self.status(MAV_SEVERITY_INFO, "Landing detected")
            task = self.navigator.task
            if isinstance(task, MissionRun | ReturnRun):
                task.landed()
            self.navigator.clear()
            self.commander.reset()

    def _disarm_after_landing(self, t_us: int) -> None:
        delay_s = self.params["COM_DISARM_LAND"]
        if self.landed_at_us is not None and delay_s > 0 and t_us - self.landed_at_us >= delay_s * 1e6:
            self.landed_at_us = None
            self.disarm()
            self.status(MAV_SEVERITY_INFO, "Disarmed by landing")

