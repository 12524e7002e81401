"""A planned mission as legs in the bench's NED frame (about the scenario's home), and the distance of the true
vehicle from the leg being flown.

A leg ends at a mission item with a position and starts at the last item with a position before it (a speed
change between them has none). As PX4's own mission tests judge a flight (test/mavsdk_tests,
`check_tracks_mission`), the leg is the one toward the item MISSION_CURRENT names, and the cross-track distance is
from the straight line through its two ends; the along-track progress is how far along the leg the vehicle's
projection is (0 at its start, 1 at its end).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from firmware_interface.geodesy import LocalFrame
from hil.scenario.mission_items import RELATIVE_FRAMES, PlanItem


def item_ned(item: PlanItem, home: LocalFrame) -> np.ndarray | None:
    """Where a positional item is in the bench's NED frame about home (its altitude relative to home, or above
    sea level)."""
    where = item.lat_lon_deg
    if where is None:
        return None
    altitude_msl = item.altitude_m + (home.alt0_m if item.frame in RELATIVE_FRAMES else 0.0)
    return np.array(home.to_ned(where[0], where[1], altitude_msl))


@dataclass(frozen=True)
class Leg:
    start_ned: np.ndarray
    end_ned: np.ndarray

    @property
    def length_m(self) -> float:
        return float(np.linalg.norm(self.end_ned - self.start_ned))

    def cross_and_along(self, pos_ned: np.ndarray) -> tuple[float, float]:
        """(distance from the leg's line in m, progress along the leg as a fraction of its length)."""
        direction = self.end_ned - self.start_ned
        length = math.sqrt(float(direction @ direction))
        offset = pos_ned - self.start_ned
        if length < 1e-6:  # a leg of no length: the distance from its point
            return float(np.linalg.norm(offset)), 1.0
        along = float(offset @ direction) / length
        across = offset - direction * (along / length)
        return float(np.linalg.norm(across)), along / length


class PlannedPath:
    """The legs of a planned mission, by the sequence number of the item each leads to."""

    def __init__(self, items: list[PlanItem], home: LocalFrame) -> None:
        self.count = len(items)
        points = [item_ned(item, home) for item in items]
        self.points = {seq: p for seq, p in enumerate(points) if p is not None}
        self.legs: dict[int, Leg] = {}
        previous: np.ndarray | None = None
        for seq, point in enumerate(points):
            if point is None:
                continue
            if previous is not None:
                self.legs[seq] = Leg(previous, point)
            previous = point

    def leg_to(self, seq: int) -> Leg | None:
        """The leg flown while the board's current item is `seq`; None where there is none (the take-off, an item
        without a position)."""
        return self.legs.get(seq)
