"""WGS84 local tangent plane about an origin, to first order: what flight code does with lat/lon.

north = Δlat·(M + h0), east = Δlon·(N + h0)·cos(lat0), down = h0 − h, with M and N the meridian and
prime-vertical radii of curvature at the origin. Exact at the origin; ~d²/2R away from it (1 mm
at 100 m) — fine for a flight area, and cheap enough for every step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

WGS84_A = 6_378_137.0
WGS84_E2 = 6.69437999014e-3
STANDARD_GRAVITY_M_S2 = 9.80665  # g_n (CGPM 1901): the flight code's and the sensors' g, as PX4's CONSTANTS_ONE_G


@dataclass(frozen=True)
class LocalFrame:
    lat0_deg: float
    lon0_deg: float
    alt0_m: float

    @property
    def _scales(self) -> tuple[float, float]:
        """Metres per radian of latitude and of longitude at the origin."""
        phi = math.radians(self.lat0_deg)
        w = math.sqrt(1 - WGS84_E2 * math.sin(phi) ** 2)
        meridian = WGS84_A * (1 - WGS84_E2) / w**3
        prime_vertical = WGS84_A / w
        return meridian + self.alt0_m, (prime_vertical + self.alt0_m) * math.cos(phi)

    def to_ned(self, lat_deg: float, lon_deg: float, alt_m: float) -> tuple[float, float, float]:
        m_lat, m_lon = self._scales
        return (math.radians(lat_deg - self.lat0_deg) * m_lat, math.radians(lon_deg - self.lon0_deg) * m_lon,
                self.alt0_m - alt_m)

    def to_geodetic(self, north: float, east: float, down: float) -> tuple[float, float, float]:
        m_lat, m_lon = self._scales
        return (self.lat0_deg + math.degrees(north / m_lat), self.lon0_deg + math.degrees(east / m_lon),
                self.alt0_m - down)
