"""AUTO.RTL to home, as PX4 v1.15.4's RtlDirect flies it for a multicopter (navigator/rtl_direct.cpp, rtl.cpp):
climb straight up to the return altitude, fly home at it, descend to RTL_DESCEND_ALT above home, wait
RTL_LAND_DELAY (< 0: loiter there for good), land.

The return altitude is RTL.cpp's calculate_return_alt_from_cone_half_angle: RTL_RETURN_ALT above home; within
RTL_MIN_DIST of home only as high as the cone of half angle RTL_CONE_ANG over home asks, but at least
2·NAV_ACC_RAD; within NAV_ACC_RAD twice the distance; never lower than the vehicle is.
"""

from __future__ import annotations

import math

import numpy as np
from pymavlink.dialects.v20.common import MAV_SEVERITY_INFO

from firmware_interface.emulator.control import VehicleState
from firmware_interface.emulator.navigator import Navigator, last_at_rest, state_setpoint
from firmware_interface.emulator.px4_params import Px4Values
from firmware_interface.emulator.trajectory import Move


def return_altitude(p: Px4Values, home: np.ndarray, here: np.ndarray) -> float:
    """Height above home to return at, for the vehicle at `here` (both local NED)."""
    acceptance, min_dist = p["NAV_ACC_RAD"], p["RTL_MIN_DIST"]
    cone_deg, return_alt = p["RTL_CONE_ANG"], p["RTL_RETURN_ALT"]
    distance = math.hypot(float(here[0] - home[0]), float(here[1] - home[1]))
    height_now = float(home[2] - here[2])
    if cone_deg <= 0:
        return max(return_alt, height_now)
    if distance <= acceptance:
        height = 2 * distance
    else:
        height = return_alt
        if distance <= min_dist:
            cone = math.radians(min(max(cone_deg, 1.0), 89.0))
            height = min(distance / math.tan(cone), height)
        height = max(height, 2 * acceptance)
    return max(height, height_now)


class ReturnRun:
    def __init__(self, navigator: Navigator, state: VehicleState, t_us: int) -> None:
        self.navigator = navigator
        navigator.task = self
        home = navigator.vehicle.home_ned()
        assert home is not None
        self.home = home
        self.taking_off = False
        self.move: Move | None = None
        self.hold_until_us: int | None = None
        height = return_altitude(navigator.params, home, state.pos_ned)
        self.return_down = float(home[2]) - height
        descend = min(navigator.params["RTL_DESCEND_ALT"], height)
        self.descend_down = float(home[2]) - descend
        amsl = math.ceil(navigator.altitude_amsl(self.return_down))
        navigator.vehicle.status(MAV_SEVERITY_INFO, f"RTL: start return at {amsl} m ({math.ceil(height)} m above "
                                 "destination)")
        if navigator.last is None:
            navigator.last = state_setpoint(state)
        if float(state.pos_ned[2]) > self.return_down:
            self.stage = "climb"
            stop = navigator.stop_point()  # straight up from where the vehicle comes to rest
            self.move = navigator.move_to(np.array((stop[0], stop[1], self.return_down)), t_us, None)
        else:
            self._return(t_us)

    def _return(self, t_us: int) -> None:
        self.stage = "return"
        last = self.navigator.last
        assert last is not None
        north, east = float(self.home[0] - last.pos_ned[0]), float(self.home[1] - last.pos_ned[1])
        yaw = math.atan2(east, north) if math.hypot(north, east) > 1.0 else None
        self.move = self.navigator.move_to(np.array((self.home[0], self.home[1], self.return_down)), t_us, yaw)

    def tick(self, state: VehicleState, t_us: int) -> None:
        navigator, params = self.navigator, self.navigator.params
        if self.stage == "climb" and navigator.altitude_reached(state, self.return_down):
            self._return(t_us)
        elif self.stage == "return" and self._over_home(state, self.return_down):
            self.stage = "descend"
            self.move = navigator.move_to(np.array((self.home[0], self.home[1], self.descend_down)), t_us, None)
        elif self.stage == "descend" and self._over_home(state, self.descend_down) and self.move is not None \
                and self.move.finished(t_us):
            delay = params["RTL_LAND_DELAY"]
            self.stage = "wait"
            if delay < 0:
                navigator.vehicle.status(MAV_SEVERITY_INFO, "RTL: completed, loitering")
            self.hold_until_us = None if delay < 0 else t_us + round(delay * 1e6)
        elif self.stage == "wait" and self.hold_until_us is not None and t_us >= self.hold_until_us:
            self.stage = "land"
            navigator.vehicle.status(MAV_SEVERITY_INFO, "RTL: land at destination")
            navigator.descend_from(last_at_rest(navigator))

    def landed(self) -> None:
        """The land detector fired: the return is over (the board leaves the mode and disarms)."""
        self.navigator.task = None

    def _over_home(self, state: VehicleState, down: float) -> bool:
        params = self.navigator.params
        close_xy = math.hypot(float(state.pos_ned[0] - self.home[0]),
                              float(state.pos_ned[1] - self.home[1])) <= params["NAV_ACC_RAD"]
        return close_xy and abs(float(state.pos_ned[2]) - down) <= params["NAV_MC_ALT_RAD"]
