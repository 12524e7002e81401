"""PX4's own integration test cases, written again with MAVSDK-Python: test/mavsdk_tests of PX4-Autopilot v1.15.4
(autopilot_tester.cpp, test_multicopter_mission.cpp, test_multicopter_offboard.cpp), with their steps, their
criteria and their timeouts.

As PX4's `poll_condition_with_timeout`, a timeout runs on the vehicle's clock (ATTITUDE_QUATERNION's timestamp) once
a vehicle is connected, and on the host's before: a bench paced at a speed factor, or a host that falls behind,
waits as long in the vehicle's time as PX4's tests do. Each criterion that fails is kept (PX4's CHECK) rather than
raised, except where PX4's test REQUIREs it (the flight cannot go on), so that the test can say everything that went
wrong and compare the script's verdicts with the bench's.
"""

from __future__ import annotations

import asyncio
import math
import subprocess
import time
import warnings
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import Any

from tests.support.mavsdk_client import new_system, stop_server

with warnings.catch_warnings():
    warnings.simplefilter("ignore", FutureWarning)  # MAVSDK 3 asks to be pinned below 4: it is
    from mavsdk.mission import MissionError, MissionItem, MissionPlan
    from mavsdk.offboard import OffboardError, PositionNedYaw
    from mavsdk.telemetry import LandedState

EARTH_RADIUS_M = 6_371_000.0  # a local plane about home is enough for legs of tens of metres (mm at 100 m)
BENCH_POLL_S, BENCH_GONE_GRACE_S = 0.5, 5.0  # how often the bench is looked at; a flight's time to end after it
OFFBOARD_ACCEPTANCE_M = 0.3  # test_multicopter_offboard.cpp: acceptance_radius
# test_multicopter_offboard.cpp "Offboard position control": take-off point, three setpoints, back (N, E, D, yaw)
OFFBOARD_SETPOINTS = ((0.0, 0.0, -2.0, 0.0), (0.0, 5.0, -2.0, 180.0), (5.0, 5.0, -4.0, 180.0), (5.0, 0.0, -4.0, 90.0),
                      (0.0, 0.0, -2.0, 0.0))


class Required(AssertionError):
    """A REQUIRE of PX4's test failed: the flight cannot go on."""


@dataclass
class Findings:
    """What the script saw, each failed criterion as one line."""

    failures: list[str] = field(default_factory=list)
    takeoff_altitude_m: float | None = None  # MIS_TAKEOFF_ALT, as MAVSDK reads it
    hover_altitude_m: float | None = None  # the relative altitude once within 10 % of it
    offboard_errors_m: list[float] = field(default_factory=list)  # distance from each setpoint when reached
    mission_finished: bool = False
    max_cross_track_m: float = 0.0  # from the leg being flown, at 5 Hz, as check_tracks_mission measures it
    disarmed: bool = False

    def check(self, ok: bool, what: str) -> bool:
        if not ok:
            self.failures.append(what)
        return ok


def local_ned(lat_deg: float, lon_deg: float, origin: tuple[float, float]) -> tuple[float, float]:
    """North and east of `origin` (lat, lon), m, on a plane tangent at it."""
    north = math.radians(lat_deg - origin[0]) * EARTH_RADIUS_M
    east = math.radians(lon_deg - origin[1]) * EARTH_RADIUS_M * math.cos(math.radians(origin[0]))
    return north, east


def global_of(north: float, east: float, origin: tuple[float, float]) -> tuple[float, float]:
    return (origin[0] + math.degrees(north / EARTH_RADIUS_M),
            origin[1] + math.degrees(east / (EARTH_RADIUS_M * math.cos(math.radians(origin[0])))))


def point_to_line_m(point: tuple[float, ...], start: tuple[float, ...], end: tuple[float, ...]) -> float:
    """math_helpers.h point_to_line_distance: from the straight line through start and end."""
    d = [e - s for s, e in zip(start, end, strict=True)]
    length = math.sqrt(sum(c * c for c in d)) or 1.0
    u = [c / length for c in d]
    t = sum(uc * (p - s) for uc, p, s in zip(u, point, start, strict=True))
    closest = [s + t * uc for s, uc in zip(start, u, strict=True)]
    return math.dist(closest, point)


class MavsdkTester:
    """One MAVSDK connection and what it has heard (each telemetry stream followed by a task of its own)."""

    def __init__(self, findings: Findings) -> None:
        self.findings = findings
        self.drone = new_system()
        self.vehicle_us = 0  # ATTITUDE_QUATERNION's timestamp: the vehicle's clock
        self.latest: dict[str, Any] = {}
        self.heard_s: dict[str, float] = {}  # when each stream last gave a value (host monotonic), for diagnosis
        self._tasks: list[asyncio.Task[None]] = []

    # --- connection and the vehicle's clock ----------------------------------------------
    async def connect(self, url: str) -> None:
        try:  # autopilot_tester.cpp: a system within 25 s (bounded even if mavsdk_server never answers or reports)
            await asyncio.wait_for(self._connected(url), 25)
        except TimeoutError:
            raise Required(f"no system connected on {url} within 25 s") from None
        for name, stream in (("attitude", self.drone.telemetry.attitude_quaternion()),
                             ("position", self.drone.telemetry.position()),
                             ("ned", self.drone.telemetry.position_velocity_ned()),
                             ("armed", self.drone.telemetry.armed()),
                             ("landed", self.drone.telemetry.landed_state()),
                             ("mode", self.drone.telemetry.flight_mode()),
                             ("health", self.drone.telemetry.health()),
                             ("all_ok", self.drone.telemetry.health_all_ok())):
            self._tasks.append(asyncio.create_task(self._follow(name, stream)))

    async def _follow(self, name: str, stream: Any) -> None:
        async for value in stream:
            self.latest[name] = value
            self.heard_s[name] = time.monotonic()
            if name == "attitude":
                self.vehicle_us = max(self.vehicle_us, value.timestamp_us)

    async def poll(self, condition: Callable[[], bool], timeout_s: float) -> bool:
        """poll_condition_with_timeout: the condition, checked 100 times per timeout, on the vehicle's clock."""
        start_us, start_wall = self.vehicle_us, time.monotonic()
        while not condition():
            await asyncio.sleep(min(timeout_s / 100, 0.1))
            waited = (self.vehicle_us - start_us) * 1e-6 if start_us else time.monotonic() - start_wall
            if waited > timeout_s:
                return False
        return True

    async def close(self) -> None:
        for task in self._tasks:
            task.cancel()
        await asyncio.gather(*self._tasks, return_exceptions=True)
        stop_server(self.drone)

    # --- the steps of autopilot_tester.cpp --------------------------------------------------
    async def _connected(self, url: str) -> None:
        await self.drone.connect(system_address=url)
        async for state in self.drone.core.connection_state():
            if state.is_connected:
                return

    async def wait_until_ready(self) -> None:
        """Health all ok within 30 s, then armable within 20 s."""
        self.findings.check(await self.poll(lambda: self.latest.get("all_ok") is True, 30),
                            "health not all ok within 30 s")
        self.findings.check(await self.poll(lambda: self._health("is_armable"), 20), "not armable within 20 s")

    def _health(self, flag: str) -> bool:
        health = self.latest.get("health")
        return bool(health is not None and getattr(health, flag))

    async def arm(self) -> None:
        await self.drone.action.arm()  # an ActionError is a failed REQUIRE

    async def takeoff_and_hover(self) -> None:
        """takeoff(), wait_until_hovering() (InAir within 45 s), and the take-off altitude within 10 %."""
        altitude = await self.drone.action.get_takeoff_altitude()
        self.findings.takeoff_altitude_m = altitude
        await self.drone.action.takeoff()
        in_air = await self.poll(lambda: self.latest.get("landed") == LandedState.IN_AIR, 45)
        self.findings.check(in_air, "not in the air within 45 s of take-off")
        reached = await self.poll(lambda: abs(self._relative_altitude() - altitude) <= 0.1 * altitude, 45)
        self.findings.hover_altitude_m = self._relative_altitude()
        self.findings.check(reached, f"take-off altitude {altitude:g} m not reached within 10 % "
                                     f"(at {self._relative_altitude():.2f} m)")

    def _relative_altitude(self) -> float:
        position = self.latest.get("position")
        return float(position.relative_altitude_m) if position is not None else math.nan

    async def offboard_setpoints(self, timeout_s: float = 10.0) -> None:
        """offboard_goto() to each setpoint of "Offboard position control": within 0.3 m of the estimated
        position, each within 10 s."""
        first = OFFBOARD_SETPOINTS[0]
        await self.drone.offboard.set_position_ned(PositionNedYaw(*first))
        try:
            await self.drone.offboard.start()
        except OffboardError as exc:
            raise Required(f"offboard refused: {exc}") from exc
        for target in OFFBOARD_SETPOINTS:
            await self.drone.offboard.set_position_ned(PositionNedYaw(*target))
            reached = await self.poll(lambda t=target: self._distance_to(t) < OFFBOARD_ACCEPTANCE_M, timeout_s)
            self.findings.offboard_errors_m.append(self._distance_to(target))
            self.findings.check(reached, f"offboard setpoint {target[:3]} not within {OFFBOARD_ACCEPTANCE_M} m in "
                                         f"{timeout_s:g} s (at {self._distance_to(target):.2f} m; {self._state()})")
        await self.drone.offboard.stop()

    def _state(self) -> str:
        """The flight mode and how long ago (host time) each stream the criteria read last gave a value: a failed
        criterion then says whether PX4 did something else or the client stopped hearing it."""
        now = time.monotonic()
        ages = ", ".join(f"{name} {now - self.heard_s[name]:.1f} s ago" for name in ("attitude", "ned", "mode")
                         if name in self.heard_s)
        return f"mode {self.latest.get('mode')}; heard {ages}"

    def _distance_to(self, target: tuple[float, ...]) -> float:
        ned = self.latest.get("ned")
        if ned is None:
            return math.inf
        p = ned.position
        return math.dist((p.north_m, p.east_m, p.down_m), target[:3])

    async def land_and_wait_disarmed(self) -> None:
        await self.drone.action.land()
        await self.wait_until_disarmed(180)  # "Takeoff and Land": until_disarmed_timeout

    async def wait_until_disarmed(self, timeout_s: float) -> None:
        disarmed = await self.poll(lambda: self.latest.get("armed") is False, timeout_s)
        self.findings.disarmed = disarmed
        if not disarmed:
            raise Required(f"not disarmed within {timeout_s:g} s")

    # --- "Fly square Multicopter Missions including RTL" ----------------------------------------
    async def upload_square_mission(self, home: tuple[float, float], leg_m: float = 20.0,
                                    altitude_m: float = 10.0) -> list[tuple[float, float]]:
        """prepare_square_mission() with rtl_at_end, and a fourth corner back over home: the waypoints' lat, lon."""
        corners = [global_of(n, e, home) for n, e in ((leg_m, 0.0), (leg_m, leg_m), (0.0, leg_m), (0.0, 0.0))]
        items = [MissionItem(lat, lon, altitude_m, math.nan, False, math.nan, math.nan,
                             MissionItem.CameraAction.NONE, math.nan, math.nan, math.nan, math.nan, math.nan,
                             MissionItem.VehicleAction.NONE) for lat, lon in corners]
        await self.drone.mission.set_return_to_launch_after_mission(True)
        await self.drone.mission.upload_mission(MissionPlan(items))
        return corners

    async def execute_mission_tracked(self, home: tuple[float, float], altitude_m: float,
                                      corridor_m: float = 5.0) -> None:
        """check_tracks_mission(5 m) while execute_mission(): started within 3 s, finished within 90 s."""
        mission = (await self.drone.mission.download_mission()).mission_items
        legs = [(*local_ned(i.latitude_deg, i.longitude_deg, home), -i.relative_altitude_m) for i in mission]
        progress: dict[str, int] = {"current": 0, "total": len(legs)}
        tracker = asyncio.create_task(self._track(legs, progress, corridor_m, home))
        follower = asyncio.create_task(self._follow_progress(progress))
        try:
            started = await self._start_mission_within(3.0)
            if not started:
                raise Required("the mission did not start within 3 s")
            finished = await self.poll(lambda: progress["current"] == progress["total"], 90)
            self.findings.mission_finished = finished
            self.findings.check(finished, f"mission not finished within 90 s (at item {progress['current']} of "
                                          f"{progress['total']})")
        finally:
            for task in (tracker, follower):
                task.cancel()
            await asyncio.gather(tracker, follower, return_exceptions=True)

    async def _start_mission_within(self, timeout_s: float) -> bool:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            try:
                await self.drone.mission.start_mission()
                return True
            except MissionError:  # until the vehicle accepts: retried, as PX4's test does
                await asyncio.sleep(0.1)
        return False

    async def _follow_progress(self, progress: dict[str, int]) -> None:
        async for update in self.drone.mission.mission_progress():
            progress["current"], progress["total"] = update.current, update.total

    async def _track(self, legs: list[tuple[float, float, float]], progress: dict[str, int], corridor_m: float,
                     home: tuple[float, float]) -> None:
        await self.drone.telemetry.set_rate_position_velocity_ned(5)
        async for ned in self.drone.telemetry.position_velocity_ned():
            current = progress["current"]
            if 0 < current < progress["total"]:
                p = ned.position
                distance = point_to_line_m((p.north_m, p.east_m, p.down_m), legs[current - 1], legs[current])
                self.findings.max_cross_track_m = max(self.findings.max_cross_track_m, distance)
                self.findings.check(distance < corridor_m, f"{distance:.2f} m from leg {current}, outside the "
                                                           f"{corridor_m:g} m corridor")

    async def home(self) -> tuple[float, float]:
        async for home in self.drone.telemetry.home():
            return home.latitude_deg, home.longitude_deg
        raise Required("no home position")


async def fly(url: str, flight: Callable[[MavsdkTester], Awaitable[None]], timeout_s: float,
              bench_exit: Callable[[], int | None]) -> Findings:
    """Connect to `url` (MAVSDK 3: udpin://0.0.0.0:PORT), fly `flight`, and return what was found (a failed
    REQUIRE is in the failures, as its own line). `bench_exit` is the bench's exit code once it has ended."""
    findings = Findings()
    tester = MavsdkTester(findings)
    try:
        await tester.connect(url)
        await asyncio.wait_for(_while_the_bench_runs(flight(tester), bench_exit), timeout_s)
    except Required as exc:
        findings.failures.append(f"REQUIRE: {exc}")
    finally:
        await tester.close()
    return findings


async def _while_the_bench_runs(flying: Awaitable[None], bench_exit: Callable[[], int | None]) -> None:
    """The flight, cut short BENCH_GONE_GRACE_S after the bench has ended: with the vehicle gone a MAVSDK telemetry
    stream waits until the flight's timeout (a failed PX4 HITL flight on a stalling host held a CI run 15 minutes).
    The grace lets a flight that ends with the run (its last wait sees the disarm) finish on its own."""
    task = asyncio.ensure_future(flying)
    ended_at: float | None = None
    while True:
        done, _ = await asyncio.wait({task}, timeout=BENCH_POLL_S)
        if done:
            return task.result()
        code = bench_exit()
        if code is not None:
            ended_at = time.monotonic() if ended_at is None else ended_at
            if time.monotonic() - ended_at > BENCH_GONE_GRACE_S:
                task.cancel()
                await asyncio.gather(task, return_exceptions=True)
                raise Required(f"the bench ended (exit {code}) before the flight did")


def fly_blocking(url: str, flight: Callable[[MavsdkTester], Awaitable[None]], timeout_s: float,
                 bench: subprocess.Popen[str]) -> Findings:
    return asyncio.run(fly(url, flight, timeout_s, bench.poll))
