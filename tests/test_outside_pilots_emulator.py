"""PX4's MAVSDK test cases with an outside pilot (`pilot: external`) on the built-in emulator, which flies for a
ground station as PX4 does: the bench's relay serves MAVSDK and a second ground station at once, the bench judges
the flight on the truth, and its verdicts must agree with the script's. One flight, at the speed factor a script
allows (tests/support/outside_pilot_runs.py)."""

from __future__ import annotations

import pytest

from tests.support.outside_pilot_runs import SPEED_FACTOR, fly_through_the_relay

pytestmark = [pytest.mark.e2e, pytest.mark.slow]


def test_mavsdk_and_a_second_station_fly_the_emulator_through_the_relay(tmp_path):
    fly_through_the_relay(tmp_path, "--speed-factor", str(SPEED_FACTOR))
