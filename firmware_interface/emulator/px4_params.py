"""The PX4 parameters the emulator's commander and navigator read, with PX4's names, units and defaults.

Defaults are PX4 v1.15.4's for its HIL quadrotor (airframe 1001, which sources rc.mc_defaults: NAV_ACC_RAD 2,
RTL_RETURN_ALT 30, RTL_DESCEND_ALT 10); bounds are the @min/@max of PX4's parameter metadata. A value set
outside them is clamped into them (PX4 stores it as sent and leaves the check to the ground station).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass


@dataclass(frozen=True)
class Px4Param:
    default: float
    low: float
    high: float
    integer: bool = False  # PX4 declares it INT32 (enumerations, whole degrees)


INF = math.inf
PX4_PARAMS: dict[str, Px4Param] = {
    # mc_pos_control: how the navigator's references move (m, m/s, m/s², deg/s)
    "MPC_LAND_SPEED": Px4Param(0.7, 0.6, INF),
    "MPC_XY_CRUISE": Px4Param(5.0, 3.0, 20.0),
    "MPC_XY_VEL_MAX": Px4Param(12.0, 0.0, 20.0),
    "MPC_Z_VEL_MAX_UP": Px4Param(3.0, 0.5, 8.0),
    "MPC_Z_VEL_MAX_DN": Px4Param(1.5, 0.5, 4.0),
    "MPC_TKO_SPEED": Px4Param(1.5, 1.0, 5.0),
    "MPC_ACC_HOR": Px4Param(3.0, 2.0, 15.0),
    "MPC_ACC_UP_MAX": Px4Param(4.0, 2.0, 15.0),
    "MPC_ACC_DOWN_MAX": Px4Param(3.0, 2.0, 15.0),
    "MPC_YAWRAUTO_MAX": Px4Param(45.0, 5.0, 360.0),
    # mc_pos_control: position control from the sticks
    "MPC_VEL_MANUAL": Px4Param(10.0, 3.0, 20.0),
    "MPC_ACC_HOR_MAX": Px4Param(5.0, 2.0, 15.0),
    "MPC_MAN_Y_MAX": Px4Param(150.0, 0.0, 400.0),
    "MPC_HOLD_DZ": Px4Param(0.1, 0.0, 1.0),
    "MPC_XY_MAN_EXPO": Px4Param(0.6, 0.0, 1.0),
    "MPC_Z_MAN_EXPO": Px4Param(0.6, 0.0, 1.0),
    "MPC_YAW_EXPO": Px4Param(0.6, 0.0, 1.0),
    # navigator
    "NAV_ACC_RAD": Px4Param(2.0, 0.05, 200.0),
    "NAV_MC_ALT_RAD": Px4Param(0.8, 0.05, 200.0),
    "MIS_TAKEOFF_ALT": Px4Param(2.5, 0.0, INF),
    "RTL_RETURN_ALT": Px4Param(30.0, 0.0, INF),
    "RTL_DESCEND_ALT": Px4Param(10.0, 0.0, INF),
    "RTL_LAND_DELAY": Px4Param(0.0, -1.0, INF),
    "RTL_MIN_DIST": Px4Param(10.0, 0.5, INF),
    "RTL_CONE_ANG": Px4Param(45.0, 0.0, 90.0, integer=True),
    # commander
    "COM_DISARM_LAND": Px4Param(2.0, -INF, INF),
    "COM_OF_LOSS_T": Px4Param(1.0, 0.0, 60.0),
    "COM_OBL_RC_ACT": Px4Param(0.0, 0.0, 7.0, integer=True),
    # commander: failsafes
    "COM_FAIL_ACT_T": Px4Param(5.0, 0.0, 25.0),
    "COM_RC_LOSS_T": Px4Param(0.5, 0.0, 35.0),
    "NAV_RCL_ACT": Px4Param(2.0, 1.0, 6.0, integer=True),
    "COM_RCL_EXCEPT": Px4Param(0.0, 0.0, 31.0, integer=True),
    "COM_DL_LOSS_T": Px4Param(10.0, 5.0, 300.0, integer=True),
    "NAV_DLL_ACT": Px4Param(0.0, 0.0, 6.0, integer=True),
    "COM_LOW_BAT_ACT": Px4Param(0.0, 0.0, 3.0, integer=True),
    "BAT_LOW_THR": Px4Param(0.15, 0.12, 0.5),
    "BAT_CRIT_THR": Px4Param(0.07, 0.05, 0.25),
    "BAT_EMERGEN_THR": Px4Param(0.05, 0.03, 0.1),
    "EKF2_NOAID_TOUT": Px4Param(5_000_000.0, 500_000.0, 10_000_000.0, integer=True),  # µs
}


class Px4Values:
    """Current values by name; `set` clamps to PX4's bounds (and rounds PX4's integers)."""

    def __init__(self, overrides: Mapping[str, float] | None = None) -> None:
        self.values = {name: p.default for name, p in PX4_PARAMS.items()}
        for name, value in (overrides or {}).items():
            self.set(name, value)

    def __getitem__(self, name: str) -> float:
        return self.values[name]

    def set(self, name: str, value: float) -> None:
        """Take a value (a NaN or infinite one is ignored)."""
        spec = PX4_PARAMS[name]
        if not math.isfinite(value):
            return
        value = min(max(float(value), spec.low), spec.high)
        self.values[name] = float(round(value)) if spec.integer else value


def unknown_names(names: list[str]) -> list[str]:
    """Names that are not among the emulator's PX4 parameters (for the configuration's validation)."""
    return [name for name in names if name not in PX4_PARAMS]
