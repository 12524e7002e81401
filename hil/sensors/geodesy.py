"""NED about the home position ⇄ WGS84, with pymap3d (a maintained geodesy library)."""

from __future__ import annotations

import pymap3d
from pydantic import BaseModel, ConfigDict, Field

MAX_DISTANCE_M = 10_000.0  # from home: a take-off at 1.5 m/s reaches it within two hours


class Home(BaseModel):
    """The NED origin of a run (the scenario's `home`); by default PX4's SITL home, Zurich Irchel Park."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    lat_deg: float = Field(47.397742, ge=-90, le=90)
    lon_deg: float = Field(8.545594, ge=-180, le=180)
    alt_msl_m: float = Field(488.0, ge=-MAX_DISTANCE_M, le=MAX_DISTANCE_M)


def ned_to_geodetic(n: float, e: float, d: float, home: Home) -> tuple[float, float, float]:
    """(lat deg, lon deg, altitude m) of a NED point; altitude is measured like the home altitude."""
    lat, lon, alt = pymap3d.ned2geodetic(n, e, d, home.lat_deg, home.lon_deg, home.alt_msl_m)
    return float(lat), float(lon), float(alt)


def geodetic_to_ned(lat_deg: float, lon_deg: float, alt_m: float, home: Home) -> tuple[float, float, float]:
    n, e, d = pymap3d.geodetic2ned(lat_deg, lon_deg, alt_m, home.lat_deg, home.lon_deg, home.alt_msl_m)
    return float(n), float(e), float(d)
