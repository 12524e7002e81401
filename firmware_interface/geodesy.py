"""WGS84 local tangent plane about an origin, to first order: what flight code does with lat/lon.

north = Δlat·(M + h0), east = Δlon·(N + h0)·cos(lat0), down = h0 − h, with M and N the meridian and
prime-vertical radii of curvature at the origin. Exact at the origin; ~d²/2R away from it (1 mm
at 100 m) — fine for a flight area, and cheap enough for every step.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from firmware_interface.compiled_code import CompiledCode

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

    @cached_property
    def constants(self) -> tuple[float, float, float, float, float]:
        """(lat0 deg, lon0 deg, alt0 m, metres per radian of latitude, of longitude), what `geodetic_of` takes
        (compiled code as a float64 array)."""
        return (self.lat0_deg, self.lon0_deg, self.alt0_m, *self._scales)

    def to_ned(self, lat_deg: float, lon_deg: float, alt_m: float) -> tuple[float, float, float]:
        m_lat, m_lon = self._scales
        return (math.radians(lat_deg - self.lat0_deg) * m_lat, math.radians(lon_deg - self.lon0_deg) * m_lon,
                self.alt0_m - alt_m)

    def to_geodetic(self, north: float, east: float, down: float) -> tuple[float, float, float]:
        return geodetic_of(north, east, down, self.constants)


@CompiledCode.inline
def geodetic_of(north: float, east: float, down: float,
                frame: Sequence[float] | np.ndarray) -> tuple[float, float, float]:
    """(lat deg, lon deg, altitude m) of a NED point about the frame whose `LocalFrame.constants` are `frame`."""
    return (frame[0] + math.degrees(north / frame[3]), frame[1] + math.degrees(east / frame[4]), frame[2] - down)
