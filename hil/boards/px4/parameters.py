"""What a PX4 the bench started is told about the simulated vehicle, as a user configures a real one."""

from __future__ import annotations

from hil.scenario.schema import Scenario
from hil.sensors.config import GPS_PROFILES, resolve


def px4_parameters(scenario: Scenario) -> dict[str, float]:
    """EKF2_GPS_DELAY (ms) is the receiver's delay (PX4 SITL's own default of 10 ms assumes a delay-free
    simulator GPS)."""
    gps = resolve(GPS_PROFILES, scenario.sensors.gps.profile, scenario.sensors.gps.overrides)
    return {"EKF2_GPS_DELAY": round(gps.delay_s * 1000.0, 3)}
