"""The run's home and its one geodesy: NED about home ⇄ WGS84 in the tangent-plane model of
`firmware_interface.geodesy.LocalFrame`, for the GPS, the truth sent to the board and the recording alike.

The plant's world is flat NED, so lat/lon are a map of it, not a measurement: the bench uses the same
first-order model as the flight code (exactly invertible, ~d²/2R from the ellipsoid: 1 mm at 100 m, 85 mm
at 1 km, checked against pymap3d in the tests) and costs ~0.4 µs a point, where pymap3d's exact
conversion costs ~75 µs — too much for a truth message every step.
"""

from __future__ import annotations

from functools import cached_property

from pydantic import BaseModel, ConfigDict, Field

from firmware_interface.geodesy import LocalFrame

MAX_DISTANCE_M = 10_000.0  # from home: a take-off at 1.5 m/s reaches it within two hours


class Home(BaseModel):
    """The NED origin of a run (the scenario's `home`); by default PX4's SITL home, Zurich Irchel Park."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True, ignored_types=(cached_property,))

    lat_deg: float = Field(47.397742, ge=-90, le=90)
    lon_deg: float = Field(8.545594, ge=-180, le=180)
    alt_msl_m: float = Field(488.0, ge=-MAX_DISTANCE_M, le=MAX_DISTANCE_M)

    @cached_property
    def frame(self) -> LocalFrame:
        """The local tangent frame about home: every lat/lon of the run goes through it."""
        return LocalFrame(self.lat_deg, self.lon_deg, self.alt_msl_m)


def ned_to_geodetic(n: float, e: float, d: float, home: Home) -> tuple[float, float, float]:
    """(lat deg, lon deg, altitude m) of a NED point; altitude is measured like the home altitude."""
    return home.frame.to_geodetic(n, e, d)


def geodetic_to_ned(lat_deg: float, lon_deg: float, alt_m: float, home: Home) -> tuple[float, float, float]:
    return home.frame.to_ned(lat_deg, lon_deg, alt_m)
