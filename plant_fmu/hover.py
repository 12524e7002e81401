"""Hover physics of the plant's rotor model, used by demos and the emulator's config checks."""

from __future__ import annotations

import math


def rotor_command_for_thrust(thrust_n: float, thrust_max_n: float, curve_k: float) -> float:
    """Invert T = T_max((1-k)u + k u^2) for u in [0, 1]."""
    ratio = thrust_n / thrust_max_n
    if curve_k == 0:
        return ratio
    return (-(1 - curve_k) + math.sqrt((1 - curve_k) ** 2 + 4 * curve_k * ratio)) / (2 * curve_k)


def hover_command(mass_kg: float, g: float, thrust_max_n: float, curve_k: float) -> float:
    """The equal command on four rotors whose total thrust equals the weight."""
    return rotor_command_for_thrust(mass_kg * g / 4, thrust_max_n, curve_k)
