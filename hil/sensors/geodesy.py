"""NED about the home position ⇄ WGS84, with pymap3d (a maintained geodesy library)."""

from __future__ import annotations

from dataclasses import dataclass

import pymap3d


@dataclass(frozen=True)
class Home:
    """PX4's default SITL home: Zurich Irchel Park, 488 m AMSL."""

    lat_deg: float = 47.397742
    lon_deg: float = 8.545594
    alt_msl_m: float = 488.0


def ned_to_geodetic(n: float, e: float, d: float, home: Home) -> tuple[float, float, float]:
    """(lat deg, lon deg, altitude m) of a NED point; altitude is measured like the home altitude."""
    lat, lon, alt = pymap3d.ned2geodetic(n, e, d, home.lat_deg, home.lon_deg, home.alt_msl_m)
    return float(lat), float(lon), float(alt)


def geodetic_to_ned(lat_deg: float, lon_deg: float, alt_m: float, home: Home) -> tuple[float, float, float]:
    n, e, d = pymap3d.geodetic2ned(lat_deg, lon_deg, alt_m, home.lat_deg, home.lon_deg, home.alt_msl_m)
    return float(n), float(e), float(d)
