"""The flight itself judged, with or without `expect`: a vehicle that never leaves the ground, hits the
ground during its flight or tumbles has failed, whatever its tracking numbers say."""

from __future__ import annotations

import math
from collections.abc import Callable

When = Callable[[], str]  # the moment as a user reads it, worded only for a failure (a step's judging costs no text)

LIFTOFF_M = 0.3  # above this the vehicle has left the ground
TUMBLE_DEG = 75.0  # roll or pitch beyond this is a vehicle out of control (the controllers tilt ≤ 35°)


class FlightFailed(Exception):
    """The vehicle did what no flight should; the message says what and when."""


class FlightJudge:
    """Fed the true state each step of take-off and mission."""

    def __init__(self) -> None:
        self.airborne = False

    def take_off_step(self, height_m: float, on_ground: bool, roll: float, pitch: float, when: When) -> None:
        self._common(height_m, on_ground, roll, pitch, when)

    def mission_step(self, height_m: float, on_ground: bool, roll: float, pitch: float, when: When) -> None:
        if not self.airborne:
            raise FlightFailed(f"the vehicle never left the ground (height {max(height_m, 0.0):.2f} m when the "
                               f"mission started {when()}): its thrust never lifted it (too heavy, rotors too "
                               "weak, or the flight code asks too little)")
        self._common(height_m, on_ground, roll, pitch, when)

    def _common(self, height_m: float, on_ground: bool, roll: float, pitch: float, when: When) -> None:
        if height_m > LIFTOFF_M:
            self.airborne = True
        elif on_ground and self.airborne:
            raise FlightFailed(f"the vehicle hit the ground {when()}")
        self.tumble_check(roll, pitch, when)

    @staticmethod
    def tumble_check(roll: float, pitch: float, when: When) -> None:
        """Beyond TUMBLE_DEG of roll or pitch the vehicle is out of control, whoever flies it."""
        tilt = max(abs(roll), abs(pitch))
        if math.degrees(tilt) > TUMBLE_DEG:
            raise FlightFailed(f"the vehicle tumbled {when()}: roll {math.degrees(roll):+.0f}°, "
                               f"pitch {math.degrees(pitch):+.0f}° (beyond ±{TUMBLE_DEG:g}°)")
