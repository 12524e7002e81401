"""The units a plant mapping may name, each with its quantity and its factor to SI.

A small table rather than a units library: the ports of the contract need a dozen quantities, FMUs spell
units the Modelica way (`m/s2`, `N.m`, `rad/s`), which general parsers read differently or not at all, and
an explicit table says exactly what the bench accepts (docs/plant.md argues it).
"""

from __future__ import annotations

import math
from typing import Literal

Quantity = Literal["length", "speed", "acceleration", "angle", "angular_rate", "force", "torque", "mass",
                   "voltage", "current", "charge", "resistance", "dimensionless", "boolean"]

_FT, _LBF = 0.3048, 4.4482216152605
_DEG = math.pi / 180

# unit -> (quantity, SI value of one unit)
UNITS: dict[str, tuple[Quantity, float]] = {
    "m": ("length", 1.0), "cm": ("length", 0.01), "mm": ("length", 0.001), "km": ("length", 1000.0),
    "ft": ("length", _FT), "in": ("length", 0.0254),
    "m/s": ("speed", 1.0), "km/h": ("speed", 1 / 3.6), "ft/s": ("speed", _FT), "kn": ("speed", 1852 / 3600),
    "m/s2": ("acceleration", 1.0), "m/s^2": ("acceleration", 1.0), "ft/s2": ("acceleration", _FT),
    "rad": ("angle", 1.0), "deg": ("angle", _DEG),
    "rad/s": ("angular_rate", 1.0), "deg/s": ("angular_rate", _DEG), "rpm": ("angular_rate", 2 * math.pi / 60),
    "rev/min": ("angular_rate", 2 * math.pi / 60),
    "N": ("force", 1.0), "kN": ("force", 1000.0), "lbf": ("force", _LBF),
    "N.m": ("torque", 1.0), "N*m": ("torque", 1.0), "lbf.ft": ("torque", _LBF * _FT),
    "kg": ("mass", 1.0), "g": ("mass", 0.001), "lb": ("mass", 0.45359237),
    "V": ("voltage", 1.0), "mV": ("voltage", 0.001),
    "A": ("current", 1.0), "mA": ("current", 0.001),
    "C": ("charge", 1.0), "A.h": ("charge", 3600.0), "mA.h": ("charge", 3.6), "Ah": ("charge", 3600.0),
    "mAh": ("charge", 3.6),
    "Ohm": ("resistance", 1.0), "ohm": ("resistance", 1.0), "mOhm": ("resistance", 0.001),
    "1": ("dimensionless", 1.0), "%": ("dimensionless", 0.01),
}


class UnitError(ValueError):
    """A unit not in the table, or of another quantity than the port's."""


def si_factor(unit: str, quantity: Quantity) -> float:
    """What one `unit` is in SI, after checking that it measures `quantity`."""
    if unit not in UNITS:
        raise UnitError(f"unknown unit {unit!r}; known: {', '.join(sorted(UNITS))}")
    kind, factor = UNITS[unit]
    if kind != quantity:
        needed = quantity.replace("_", " ")
        raise UnitError(f"unit {unit!r} measures {kind.replace('_', ' ')}, this port needs {needed}")
    return factor


def same_unit(a: str, b: str) -> bool:
    """Whether two spellings name the same unit (both known to the table, same quantity and factor)."""
    return a in UNITS and b in UNITS and UNITS[a] == UNITS[b]
