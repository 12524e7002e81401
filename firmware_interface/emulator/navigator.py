"""The navigator: the active mode becomes the reference (position, velocity, acceleration, yaw) the paper's
controllers track, as PX4's navigator and its multicopter trajectory generator do between them.

`setpoint` runs every control step and only samples the active reference (a hold, a quintic move, a descent,
the offboard setpoint); `tick` runs at NAVIGATOR_PERIOD_US of simulated time (PX4's navigator runs at ~20 Hz)
and decides: item reached, next stage, mode done. Every mode change starts from the last reference sampled,
so the reference stays continuous through it. Modes:

- POSCTL (no stick input) and AUTO.LOITER: brake to a stop from the last reference and hold there; on the
  ground, hold where the vehicle stands.
- AUTO.TAKEOFF: climb at MPC_TKO_SPEED to the takeoff altitude (the command's, or MIS_TAKEOFF_ALT above the
  vehicle), reached within NAV_MC_ALT_RAD (half the climb if that is less), then AUTO.LOITER.
- AUTO.LAND: descend at MPC_LAND_SPEED from where the vehicle is; the board's land detector ends it.
- AUTO.MISSION (`mission_run.py`) and AUTO.RTL (`return_run.py`).
- OFFBOARD: the other system's setpoints (`offboard.py`).
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np
from pymavlink.dialects.v20.common import MAV_SEVERITY_CRITICAL, MAV_SEVERITY_INFO

from firmware_interface.emulator.control import Setpoint, VehicleState
from firmware_interface.emulator.px4_params import Px4Values
from firmware_interface.emulator.trajectory import Descent, Hold, Limits, Move, Reference
from firmware_interface.geodesy import LocalFrame
from firmware_interface.px4_modes import FlightMode

NAVIGATOR_PERIOD_US = 50_000


class Task(Protocol):
    """A mode's decisions, taken at the navigator's rate (take-off, landing at speed, mission, return)."""

    @property
    def taking_off(self) -> bool: ...

    def tick(self, state: VehicleState, t_us: int) -> None: ...


class Vehicle(Protocol):
    """What the navigator asks of the board around it."""

    airborne: bool

    def status(self, severity: int, text: str) -> None: ...

    def mode_completed(self, mode: FlightMode) -> None: ...

    def request_mode(self, mode: FlightMode) -> None: ...

    def descent_started(self) -> None: ...

    def local_frame(self) -> LocalFrame | None: ...

    def home_ned(self) -> np.ndarray | None: ...


def at_rest(pos_ned: np.ndarray, yaw: float) -> Setpoint:
    return Setpoint(np.array(pos_ned, dtype=float), np.zeros(3), np.zeros(3), float(yaw))


def state_setpoint(state: VehicleState) -> Setpoint:
    """The vehicle where it is now, as a reference at rest."""
    return at_rest(state.pos_ned.copy(), float(state.eta[2]))


def last_at_rest(navigator: Navigator) -> Setpoint:
    """The last reference's position and yaw, at rest: where a descent starts."""
    last = navigator.last
    assert last is not None
    return at_rest(last.pos_ned.copy(), last.yaw)


class Navigator:
    def __init__(self, params: Px4Values, vehicle: Vehicle) -> None:
        self.params = params
        self.vehicle = vehicle
        self.reference: Reference | None = None  # None: hold where the vehicle is, from the next step
        self.last: Setpoint | None = None  # the last reference sampled
        self.task: Task | None = None  # what `tick` watches
        self.cruise_speed: float | None = None  # DO_CHANGE_SPEED's; None: MPC_XY_CRUISE
        self.takeoff_alt_amsl: float | None = None  # NAV_TAKEOFF's param7
        self.state: VehicleState | None = None  # the estimate of the step being flown (a blind descent reads it)
        self.next_tick_us = 0

    # --- every control step ----------------------------------------------------------------------------
    def setpoint(self, state: VehicleState, t_us: int, dt: float) -> Setpoint:
        self.state = state
        if self.reference is None:
            self.reference = Hold(state_setpoint(state))
        self.last = self.reference.sample(t_us, dt)
        return self.last

    @property
    def descending(self) -> bool:
        """Down towards the ground: a landing, or an offboard velocity down (the land detector runs)."""
        reference = self.reference
        return reference is not None and reference.descending

    @property
    def blind(self) -> bool:
        return isinstance(self.reference, BlindDescent)

    @property
    def taking_off(self) -> bool:
        return self.task is not None and self.task.taking_off

    # --- at the navigator's rate -----------------------------------------------------------------------
    def tick(self, state: VehicleState, t_us: int) -> None:
        if self.task is not None:
            self.task.tick(state, t_us)

    # --- mode changes ------------------------------------------------------------------------------------
    def clear(self) -> None:
        """Disarmed: nothing to track; the next arming starts from where the vehicle stands."""
        self.reference, self.last, self.task = None, None, None

    def hold(self, t_us: int) -> None:
        """Brake to a stop from the last reference and hold (on the ground: where the vehicle stands)."""
        self.task = None
        if self.last is None or not self.vehicle.airborne:
            self.reference = None
            return
        self.reference = Move(self.last, t_us, self.stop_point(), None, self.limits())

    def stop_point(self) -> np.ndarray:
        """Where the last reference comes to rest braking at the horizontal acceleration limit: a quintic from
        speed v to rest over T = 2·v/a covers v·T/2."""
        last = self.last
        assert last is not None
        stop_s = max(0.5, 2 * float(np.linalg.norm(last.vel_ned)) / self.limits().accel_xy)
        return last.pos_ned + last.vel_ned * stop_s / 2

    def move_to(self, target_ned: np.ndarray, t_us: int, yaw: float | None,
                line_start: np.ndarray | None = None) -> Move:
        """A move from the last reference to `target_ned`, along the line from `line_start` (None: from the last
        reference)."""
        start = self.last
        assert start is not None
        move = Move(start, t_us, target_ned, yaw, self.limits(), line_start)
        self.reference = move
        return move

    def land_here(self, state: VehicleState, t_us: int) -> None:
        """PX4's land mode: descend from where the vehicle is (the estimate, not the reference); from a move of
        the navigator's still under way, brake to a stop first."""
        last = self.last
        if isinstance(self.reference, Move) and last is not None and float(np.linalg.norm(last.vel_ned)) > 0.1:
            LandTask(self, t_us)
            return
        self.task = None
        self.descend_from(at_rest(state.pos_ned.copy(), float(state.eta[2])))

    def descend_from(self, start: Setpoint) -> None:
        start.vel_ned[2] = self.params["MPC_LAND_SPEED"]
        self.reference = Descent(start, lambda: self.params["MPC_LAND_SPEED"])
        self.vehicle.descent_started()

    def descend_blind(self, state: VehicleState) -> None:
        """PX4's Descend, for a vehicle without a position estimate: level, down at MPC_LAND_SPEED."""
        self.task = None
        self.state = state
        self.reference = BlindDescent(self, float(state.pos_ned[2]), float(state.eta[2]))
        self.vehicle.descent_started()

    def take_off(self, state: VehicleState, t_us: int) -> None:
        """AUTO.TAKEOFF, armed: climb to the commanded altitude (or MIS_TAKEOFF_ALT above the vehicle)."""
        here_amsl = self.altitude_amsl(float(state.pos_ned[2]))
        target = self.takeoff_alt_amsl
        self.takeoff_alt_amsl = None
        if target is None or not math.isfinite(target):
            default = self.params["MIS_TAKEOFF_ALT"]
            self.vehicle.status(MAV_SEVERITY_INFO, f"Using default takeoff altitude: {default:.1f} m")
            target = here_amsl + default
        if target < here_amsl:
            self.vehicle.status(MAV_SEVERITY_CRITICAL, "Already higher than takeoff altitude")
            target = here_amsl
        TakeoffTask(self, state, t_us, target - here_amsl)

    # --- helpers -------------------------------------------------------------------------------------------
    def limits(self, speed_xy: float | None = None) -> Limits:
        p = self.params
        cruise = speed_xy or self.cruise_speed or p["MPC_XY_CRUISE"]
        return Limits(min(cruise, p["MPC_XY_VEL_MAX"]) or 0.1, p["MPC_Z_VEL_MAX_UP"], p["MPC_Z_VEL_MAX_DN"],
                      p["MPC_ACC_HOR"], p["MPC_ACC_UP_MAX"], p["MPC_ACC_DOWN_MAX"],
                      math.radians(p["MPC_YAWRAUTO_MAX"]))

    def altitude_amsl(self, down_m: float) -> float:
        frame = self.vehicle.local_frame()
        return (frame.alt0_m if frame is not None else 0.0) - down_m

    def climb_limits(self) -> Limits:
        """Take-off: up at MPC_TKO_SPEED."""
        limits = self.limits()
        return Limits(limits.speed_xy, self.params["MPC_TKO_SPEED"], limits.speed_down, limits.accel_xy,
                      limits.accel_up, limits.accel_down, limits.yaw_rate)

    def altitude_reached(self, state: VehicleState, target_down: float, climb_m: float | None = None) -> bool:
        """Within NAV_MC_ALT_RAD of a height (half a take-off's climb when that is less, as PX4)."""
        radius = self.params["NAV_MC_ALT_RAD"]
        if climb_m is not None and 0 < climb_m < radius:
            radius = climb_m / 2
        return float(state.pos_ned[2]) < target_down + radius


class BlindDescent:
    """Down at MPC_LAND_SPEED with no horizontal correction (FlightTaskDescend: zero horizontal acceleration,
    'stay level to minimize horizontal drift'): the horizontal reference is the estimate itself."""

    descending = True

    def __init__(self, navigator: Navigator, down: float, yaw: float) -> None:
        self.navigator, self.down, self.yaw = navigator, down, yaw

    def sample(self, t_us: int, dt: float) -> Setpoint:
        speed = self.navigator.params["MPC_LAND_SPEED"]
        self.down += speed * dt
        state = self.navigator.state
        assert state is not None
        return Setpoint(np.array((state.pos_ned[0], state.pos_ned[1], self.down)),
                        np.array((state.vel_ned[0], state.vel_ned[1], speed)), np.zeros(3), self.yaw)


class LandTask:
    """AUTO.LAND entered at speed: brake to a stop, then descend from there."""

    taking_off = False

    def __init__(self, navigator: Navigator, t_us: int) -> None:
        self.navigator = navigator
        navigator.task = self
        last = navigator.last
        assert last is not None
        self.brake = Move(last, t_us, navigator.stop_point(), None, navigator.limits())
        navigator.reference = self.brake

    def tick(self, state: VehicleState, t_us: int) -> None:
        if self.brake.finished(t_us):
            self.navigator.task = None
            self.navigator.descend_from(last_at_rest(self.navigator))


class TakeoffTask:
    """AUTO.TAKEOFF's climb: straight up at MPC_TKO_SPEED; done once the altitude is reached."""

    taking_off = True

    def __init__(self, navigator: Navigator, state: VehicleState, t_us: int, climb_m: float) -> None:
        self.navigator = navigator
        navigator.task = self
        start = navigator.last if navigator.last is not None and navigator.vehicle.airborne else state_setpoint(state)
        self.climb_m = climb_m
        self.target = start.pos_ned - np.array((0.0, 0.0, climb_m))
        navigator.reference = Move(start, t_us, self.target, None, navigator.climb_limits())

    def tick(self, state: VehicleState, t_us: int) -> None:
        if self.navigator.altitude_reached(state, float(self.target[2]), self.climb_m):
            self.navigator.task = None
            self.navigator.vehicle.mode_completed(FlightMode.AUTO_TAKEOFF)
