"""MAVSDK, a real client, flies the emulator as PX4's "Takeoff and Land" test flies PX4: it waits for
`telemetry.health_all_ok()` and `is_armable` (which read SYS_STATUS and HOME_POSITION, MAVSDK's
telemetry_impl.cpp), arms, sets MIS_TAKEOFF_ALT through the parameter protocol, takes off, lands, and sees the
disarm. The world (plant FMU, sensors, the emulator over a pty) runs on a thread at twice real time; a UDP relay
stands where the bench's ground-station relay stands."""

from __future__ import annotations

import asyncio
import socket
import threading
import time
from typing import Any

import pytest

from tests.support.emulator_world import World
from tests.support.mavsdk_client import connected_system, free_tcp_port

pytestmark = [pytest.mark.e2e, pytest.mark.slow]
SPEED = 2.0  # simulated seconds per wall-clock second
TAKEOFF_ALT_M = 3.0


class RelayedWorld(threading.Thread):
    """The world stepped at SPEED × real time, every frame of the board relayed to MAVSDK's UDP port and back."""

    def __init__(self, world: World, mavsdk_port: int) -> None:
        super().__init__(daemon=True)
        self.world = world
        self.udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.udp.bind(("127.0.0.1", 0))
        self.udp.setblocking(False)
        self.mavsdk = ("127.0.0.1", mavsdk_port)
        self.stop = threading.Event()
        self.heights: list[tuple[float, float]] = []  # (simulated s, true height m)

    def run(self) -> None:
        world, started = self.world, time.monotonic()
        relayed = 0
        while not self.stop.is_set():
            world.step()
            self.heights.append((world.t_us * 1e-6, world.height_m()))
            for _, msg in world.received[relayed:]:
                if not msg.get_type().startswith("HIL_"):
                    self.udp.sendto(bytes(msg.get_msgbuf()), self.mavsdk)
            relayed = len(world.received)
            while True:
                try:
                    world.link.transport.write(self.udp.recv(65536))
                except BlockingIOError:
                    break
            ahead = world.t_us * 1e-6 / SPEED - (time.monotonic() - started)
            if ahead > 0:
                time.sleep(ahead)


async def takeoff_and_land(port: int, relay: RelayedWorld) -> dict[str, object]:
    async with connected_system(port) as drone:
        return await fly_takeoff_and_land(drone, relay)


async def fly_takeoff_and_land(drone: Any, relay: RelayedWorld) -> dict[str, object]:
    async for health in drone.telemetry.health():
        if health.is_global_position_ok and health.is_local_position_ok and health.is_home_position_ok \
                and health.is_armable:
            break
    seen: dict[str, object] = {"ready_at_s": relay.world.t_us * 1e-6}
    await drone.action.set_takeoff_altitude(TAKEOFF_ALT_M)
    seen["takeoff_alt_param"] = await drone.action.get_takeoff_altitude()
    await drone.action.arm()
    await drone.action.takeoff()
    async for state in drone.telemetry.landed_state():
        if str(state) == "IN_AIR":
            break
    async for position in drone.telemetry.position():
        if position.relative_altitude_m > 0.95 * TAKEOFF_ALT_M:
            break
    await asyncio.sleep(3.0 / SPEED)  # the climb ends at rest
    seen["hover_true_height_m"] = relay.world.height_m()
    async for mode in drone.telemetry.flight_mode():
        seen["mode_after_takeoff"] = str(mode)
        break
    await drone.action.land()
    async for armed in drone.telemetry.armed():
        if not armed:
            break
    seen["landed_true_height_m"] = relay.world.height_m()
    return seen


def test_mavsdk_takes_off_and_lands_the_emulator(tmp_path):
    port = free_tcp_port()  # a free port number, used here for UDP
    world = World(tmp_path)
    relay = RelayedWorld(world, port)
    relay.start()
    try:
        seen = asyncio.run(asyncio.wait_for(takeoff_and_land(port, relay), 90))
    finally:
        relay.stop.set()
        relay.join(5)
        world.close()
    assert seen["takeoff_alt_param"] == pytest.approx(TAKEOFF_ALT_M)
    assert abs(seen["hover_true_height_m"] - TAKEOFF_ALT_M) < 0.1 * TAKEOFF_ALT_M  # as PX4's test: within 10 %
    assert seen["mode_after_takeoff"] == "HOLD"
    assert seen["landed_true_height_m"] < 0.05
    assert seen["ready_at_s"] < 10.0  # healthy once the estimator has settled
