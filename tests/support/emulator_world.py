"""A minimal world for flying the emulator from a ground station in a test: the real plant FMU stepped in
lockstep with the emulator process over a real pty (HIL_SENSOR / HIL_GPS from the bench's own sensor models,
HIL_ACTUATOR_CONTROLS back), and a ground station on the same link whose frames pymavlink packs (system 255,
component 190, as QGroundControl). Results are read from the plant's true state, not from the board."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from pymavlink.dialects.v20 import common

from firmware_interface import hil_codec as codec
from firmware_interface import hil_frames
from firmware_interface.actuator_reply import ActuatorReader
from firmware_interface.link import Link, open_pty_pair
from firmware_interface.link.encoder import FrameEncoder
from hil.boards.emulator import start_emulator
from hil.scenario.vehicles import plant_parameters
from hil.sensors import Home, SensorsConfig, SensorSuite, TrueState
from plant_fmu import Plant, PlantState

RATE_HZ = 250
DT_US = 1_000_000 // RATE_HZ
GCS_SYSTEM, GCS_COMPONENT = 255, 190
START_S = 30.0  # the emulator's first heartbeat follows its flight code's compilation (seconds after an edit)
# px4_sitl noise on every sensor, without the GPS's slow (Gauss-Markov, 0.3 m) error: no board can see that error,
# so with it a position "reached" on the board is off the truth by a random walk (tests/test_controllers_closed_loop)
SENSORS = SensorsConfig(gps={"profile": "px4_sitl", "pos_markov_sigma_xy": 0.0, "pos_markov_sigma_z": 0.0})


class World:
    def __init__(self, tmp_path: Path, params: dict[str, float] | None = None, seed: int = 1,
                 sensors: SensorsConfig | None = None) -> None:
        config = tmp_path / "emulator.yaml"
        # the HIL link's own watchdog (no HIL_SENSOR for failsafe_s of wall-clock time: disarm) is not what these
        # tests judge, and on a loaded 2-core machine a test process can be descheduled for longer than 0.5 s
        config.write_text(yaml.safe_dump({"params": params or {}, "failsafe_s": 5.0}))
        self.pair = open_pty_pair()
        with open(tmp_path / "emulator.log", "wb") as log:  # as the bench starts it: forked when a server is named
            self.process = start_emulator(["--port", self.pair.slave_path, "--config", str(config)], log)
        self.link = Link(self.pair.master)  # decodes every message
        self.bench = FrameEncoder(1, 51)
        self._buffer = np.zeros(512, dtype=np.uint8)
        self.gcs = common.MAVLink(None, srcSystem=GCS_SYSTEM, srcComponent=GCS_COMPONENT)
        self.battery = common.MAVLink(None, srcSystem=1, srcComponent=180)  # MAV_COMP_ID_BATTERY of the vehicle
        self.gcs_heartbeats = True  # the GCS's 1 Hz HEARTBEAT (off: a lost data link)
        self.gps_on = True  # HIL_GPS sent (off: the receiver lost)
        self.sticks: tuple[int, int, int, int] | None = None  # MANUAL_CONTROL x, y, z, r sent at 20 Hz when set
        self.battery_percent: int | None = None  # BATTERY_STATUS from the battery component at 1 Hz when set
        self.last_gps_us = 0  # when HIL_GPS last went out
        self.home = Home()
        self.sensors = SensorSuite(sensors or SENSORS, self.home, RATE_HZ, np.random.default_rng(seed))
        self.plant = Plant(plant_parameters("inspection_quad", {}))
        self.state: PlantState = self.plant.state()
        self.t_us = 0
        self.motors: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0)
        self.actuator_reader = ActuatorReader()
        self.received: list[tuple[int, Any]] = []  # (simulated µs, message) of everything the board sent
        self.latest: dict[str, Any] = {}  # the last message of each type
        self.truth: list[tuple[int, np.ndarray]] = []  # (µs, true NED position) of every step
        self.attitudes: list[np.ndarray] = []  # true roll, pitch, yaw (rad) of every step
        self.armed = False
        self.last_sent_us = 0  # for a test's own bookkeeping of when it last sent something
        self._wait_heartbeat()
        self.pair.release_slave()

    def close(self) -> None:
        self.process.terminate()
        self.process.wait(5)
        self.link.close()
        self.plant.close()

    def _wait_heartbeat(self) -> None:
        for _ in range(int(START_S / 0.05)):
            if any(m.get_type() == "HEARTBEAT" for m in self._receive(0.05)):
                return
        raise RuntimeError("no heartbeat from the emulator")

    def _receive(self, timeout_s: float) -> list[Any]:
        messages = self.link.receive(timeout_s)
        for msg in messages:
            self.received.append((self.t_us, msg))
            self.latest[msg.get_type()] = msg
        return messages

    # --- the ground station --------------------------------------------------------------------------------
    def send(self, message: Any) -> None:
        """A pymavlink message (e.g. `world.gcs.mission_count_encode(...)`), packed by pymavlink, as the GCS."""
        self.link.transport.write(message.pack(self.gcs))

    def command(self, command: int, *params: float) -> None:
        p = tuple(params) + (0.0,) * (7 - len(params))
        self.send(self.gcs.command_long_encode(1, 1, command, 0, *p))

    def pump(self, seconds: float) -> list[Any]:
        """Read what the board sends for `seconds` of wall-clock time, without stepping the world."""
        messages: list[Any] = []
        for _ in range(max(round(seconds / 0.01), 1)):
            messages += self._receive(0.01)
        return messages

    def upload(self, items: list[Any], mission_type: int = 0, limit_s: float = 5.0) -> tuple[list[Any], Any]:
        """The mission protocol's upload as a GCS runs it: MISSION_COUNT, then each requested item; returns the
        board's requests and its MISSION_ACK (None if none came within `limit_s` of wall-clock time)."""
        self.send(self.gcs.mission_count_encode(1, 1, len(items), mission_type))
        requests: list[Any] = []
        for _ in range(round(limit_s / 0.01)):
            for msg in self._receive(0.01):
                if msg.get_type() in ("MISSION_REQUEST", "MISSION_REQUEST_INT"):
                    requests.append(msg)
                    self.send(items[msg.seq])
                elif msg.get_type() == "MISSION_ACK":
                    return requests, msg
        return requests, None

    def download(self, mission_type: int = 0, limit_s: float = 5.0) -> list[Any]:
        """MISSION_REQUEST_LIST, MISSION_REQUEST_INT for each item, MISSION_ACK; the items received in order."""
        self.send(self.gcs.mission_request_list_encode(1, 1, mission_type))
        items: list[Any] = []
        count: int | None = None
        for _ in range(round(limit_s / 0.01)):
            for msg in self._receive(0.01):
                if msg.get_type() == "MISSION_COUNT":
                    count = msg.count
                elif msg.get_type() == "MISSION_ITEM_INT":
                    items.append(msg)
                else:
                    continue
                if count is not None and len(items) < count:
                    self.send(self.gcs.mission_request_int_encode(1, 1, len(items), mission_type))
            if count is not None and len(items) == count:
                self.send(self.gcs.mission_ack_encode(1, 1, 0, mission_type))
                return items
        raise AssertionError(f"download incomplete: {len(items)} of {count} items")

    def messages(self, kind: str, since_us: int = 0) -> list[Any]:
        return [m for t, m in self.received if t >= since_us and m.get_type() == kind]

    def texts(self) -> list[str]:
        """The board's STATUSTEXTs, a text sent in chunks (one id, MAVLink 2) joined."""
        texts: list[str] = []
        for msg in self.messages("STATUSTEXT"):
            if msg.id and msg.chunk_seq:
                texts[-1] += msg.text
            else:
                texts.append(msg.text)
        return texts

    # --- the world ------------------------------------------------------------------------------------------
    def step(self) -> None:
        """One 4 ms step: plant, sensors to the board, its reply awaited (lockstep), a GCS heartbeat each second."""
        self.plant.set_input_groups(self.motors, (1.0,) * 4, np.zeros(3), np.zeros(3), np.zeros(3), 0.0)
        self.plant.step(DT_US * 1e-6)
        self.state = s = self.plant.state()
        self.t_us += DT_US
        self.truth.append((self.t_us, s.pos_ned.copy()))
        self.attitudes.append(s.rpy.copy())
        readings, gps = self.sensors.step(TrueState(self.t_us, s.pos_ned, s.vel_ned, s.q_wxyz, s.rates_frd,
                                                    s.specific_force_frd))
        self._ground_station_inputs()
        frames = b""
        row = codec.sensor_row(readings, gps)
        if gps is not None and self.gps_on:
            frames += self._packed(hil_frames.encode_hil_gps, row)
            self.last_gps_us = self.t_us
        frames += self._packed(hil_frames.encode_hil_sensor, row)
        self.link.transport.write(frames)
        self._await_reply()

    def _packed(self, packer: Callable[..., int], row: np.ndarray) -> bytes:
        """A frame of the bench's sender from one of the bench's own packers, numbered as it numbers them."""
        size = packer(self._buffer, self.bench.seq, self.bench.system_id, self.bench.component_id, row)
        self.bench.seq = (self.bench.seq + 1) & 0xFF
        return self._buffer[:size].tobytes()

    def _ground_station_inputs(self) -> None:
        if self.t_us % 1_000_000 == DT_US:
            if self.gcs_heartbeats:
                self.send(self.gcs.heartbeat_encode(6, 8, 0, 0, 0))  # MAV_TYPE_GCS, MAV_AUTOPILOT_INVALID
            if self.battery_percent is not None:
                cells = [4000, 4000, 4000] + [0xFFFF] * 7
                self.link.transport.write(self.battery.battery_status_encode(
                    0, 0, 0, 2500, cells, 500, -1, -1, self.battery_percent).pack(self.battery))
        if self.sticks is not None and self.t_us % 50_000 == 0:
            self.send(self.gcs.manual_control_encode(1, *self.sticks, 0))

    def _await_reply(self) -> None:
        for _ in range(1000):  # up to 10 s: a loaded machine may stall the emulator's process that long
            for msg in self._receive(0.01):
                if msg.get_type() == "HIL_ACTUATOR_CONTROLS" and msg.time_usec == self.t_us:
                    outputs = self.actuator_reader.read(msg.get_msgbuf())
                    assert outputs is not None, "the emulator's HIL_ACTUATOR_CONTROLS did not read as one"
                    self.motors, self.armed = outputs.motors, outputs.armed
                    return
        raise RuntimeError(f"no HIL_ACTUATOR_CONTROLS for {self.t_us} us")

    def run(self, seconds: float) -> None:
        for _ in range(round(seconds * RATE_HZ)):
            self.step()

    def run_until(self, done: Callable[[], bool], limit_s: float) -> float:
        """Step until `done()` (checked every step); the simulated seconds it took. Fails past `limit_s`."""
        start = self.t_us
        while not done():
            if (self.t_us - start) * 1e-6 > limit_s:
                raise AssertionError(f"not done within {limit_s} s of simulated time")
            self.step()
        return (self.t_us - start) * 1e-6

    def height_m(self) -> float:
        return -float(self.state.pos_ned[2])

    def geodetic(self, north: float, east: float) -> tuple[int, int]:
        """degE7 latitude and longitude of a point of the world's NED frame (the GPS's home is its origin)."""
        lat, lon, _ = self.home.frame.to_geodetic(north, east, 0.0)
        return round(lat * 1e7), round(lon * 1e7)
