"""A real ground-station client for the tests: MAVSDK (its Python package runs its own mavsdk_server)."""

from __future__ import annotations

import asyncio
import socket
import warnings
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any


def free_tcp_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def new_system() -> Any:
    """A MAVSDK System with a mavsdk_server of its own (on a free gRPC port), started at its `connect`."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)  # MAVSDK 3 asks to be pinned below 4: it is
        from mavsdk import System
    return System(port=free_tcp_port())


def stop_server(drone: Any) -> None:
    """Stop the System's mavsdk_server now, and reap it. MAVSDK-Python stops it in `System.__del__`, which runs only
    when the garbage collector gets to the System (the tasks that follow its streams hold it in a cycle): a server
    left running keeps its UDP port, the next test's server binds the port beside it (SO_REUSEPORT), and PX4's
    datagrams went to the old one (a CI run then waited out the flight's 15 min timeout)."""
    process = drone._server_process
    drone._stop_mavsdk_server()
    if process is not None:
        process.wait(10)


@asynccontextmanager
async def connected_system(udp_port: int) -> AsyncIterator[Any]:
    """A MAVSDK System listening on udpin:127.0.0.1:PORT, its mavsdk_server stopped on the way out."""
    drone = new_system()
    try:
        await drone.connect(system_address=f"udpin://127.0.0.1:{udp_port}")
        yield drone
    finally:
        stop_server(drone)


async def _read(udp_port: int, want_status_text: bool) -> dict[str, Any]:
    async with connected_system(udp_port) as drone:
        return await _what_it_reads(drone, want_status_text)


async def _what_it_reads(drone: Any, want_status_text: bool) -> dict[str, Any]:
    async for state in drone.core.connection_state():
        if state.is_connected:
            break
    seen: dict[str, Any] = {}
    async for position in drone.telemetry.position():
        seen["position"] = position
        break
    async for attitude in drone.telemetry.attitude_euler():
        seen["attitude"] = attitude
        break
    async for armed in drone.telemetry.armed():
        if armed:
            seen["armed"] = armed
            break
    async for mode in drone.telemetry.flight_mode():
        seen["flight_mode"] = str(mode)
        break
    if want_status_text:
        async for text in drone.telemetry.status_text():
            seen["status_text"] = text.text
            break
    return seen


def read_telemetry(udp_port: int, timeout_s: float, want_status_text: bool = False) -> dict[str, Any]:
    """Position, attitude, armed and flight mode (and a STATUSTEXT) as MAVSDK reports them from a vehicle
    heard on udpin:127.0.0.1:PORT; what was read before the timeout."""
    return asyncio.run(asyncio.wait_for(_read(udp_port, want_status_text), timeout_s))
