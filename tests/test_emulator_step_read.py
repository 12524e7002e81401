"""The emulator's lockstep read (`step_read`): a read of one bench step, checked and taken apart in one compiled call,
against pymavlink's packing and decoding of the same frames; and an emulator that reads its steps that way answering
byte for byte as one that reads every frame through the scanner and its messages, flying on its estimate and on the
true state."""

from __future__ import annotations

import select

import numpy as np
import pytest
from pymavlink.dialects.v20 import common

from firmware_interface.emulator import EmulatedBoard, build_config
from firmware_interface.emulator.step_read import SETPOINT, SETPOINT_FIELD_NAMES, TRUTH, StepReader
from firmware_interface.link import Link, open_pty_pair
from firmware_interface.link.transports import SerialTransport
from tests.test_emulator_sensor_frame import flight_frames

BENCH = common.MAVLink(None, srcSystem=255, srcComponent=190)
BOARD_COMPONENT = 1  # the emulator's frames; the sensor frames' component is 51, the setpoints' 190
FULL_SETPOINT = {"time_boot_ms": 1234, "target_system": 1, "target_component": 1,
                 "coordinate_frame": common.MAV_FRAME_LOCAL_NED, "type_mask": 0, "x": 1.5, "y": -2.25, "z": -12.0,
                 "vx": 0.1, "vy": -0.2, "vz": 0.3, "afx": 0.01, "afy": -0.02, "afz": 0.03, "yaw": 1.2, "yaw_rate": 0.0}
SENSOR = flight_frames()[0]


def odometry_frame(t_us: int, north_m: float = 0.1) -> bytes:
    """The true state as the bench sends it to an emulator flying on it (MAV_FRAME_LOCAL_NED, body rates in FRD)."""
    message = common.MAVLink_odometry_message(t_us, common.MAV_FRAME_LOCAL_NED, common.MAV_FRAME_BODY_FRD, north_m,
                                              0.2, -3.0, [0.9990482, 0.0261769, 0.0174524, 0.0261769], 0.01, -0.02,
                                              0.03, 0.001, -0.002, 0.003, [float("nan")] * 21, [float("nan")] * 21)
    return bytes(message.pack(BENCH))


def setpoint_frame(mavlink1: bool = False, **fields: float) -> bytes:
    message = common.MAVLink_set_position_target_local_ned_message(**{**FULL_SETPOINT, **fields})
    return bytes(message.pack(BENCH, force_mavlink1=mavlink1))


SETPOINTS = {
    "every field": setpoint_frame(),
    "position only, to system 0, MAV_FRAME_GLOBAL: the payload's zeros trimmed": setpoint_frame(
        type_mask=0b110111111000, target_system=0, target_component=0, coordinate_frame=0),
    "MAVLink 1": setpoint_frame(mavlink1=True),
}


@pytest.mark.parametrize("name", SETPOINTS)
def test_a_setpoint_then_a_sensor_frame_is_one_step_and_its_fields_are_pymavlinks(name):
    setpoint = SETPOINTS[name]
    reader = StepReader()
    assert reader.read(setpoint + SENSOR) == SETPOINT
    assert reader.ends.tolist() == [len(setpoint), len(setpoint), len(setpoint + SENSOR)]
    decoded = common.MAVLink(None).decode(bytearray(setpoint))
    assert reader.setpoint.tolist() == [float(getattr(decoded, field)) for field in SETPOINT_FIELD_NAMES]


def test_the_true_states_odometry_between_the_setpoint_and_the_sensor_frame_is_one_step_too():
    reader, setpoint, truth = StepReader(), SETPOINTS["every field"], odometry_frame(4000)
    assert reader.read(setpoint + truth + SENSOR) == SETPOINT | TRUTH
    assert reader.ends.tolist() == [len(setpoint), len(setpoint + truth), len(setpoint + truth + SENSOR)]
    assert reader.read(truth + SENSOR) == TRUTH
    assert reader.ends.tolist() == [0, len(truth), len(truth + SENSOR)]


def test_the_trimmed_setpoint_is_what_it_says():
    trimmed = SETPOINTS["position only, to system 0, MAV_FRAME_GLOBAL: the payload's zeros trimmed"]
    assert trimmed[0] == 0xFD and trimmed[1] == 50  # 53 bytes: target_system, target_component, frame dropped


def test_a_sensor_frame_alone_is_one_step_from_its_first_byte():
    reader = StepReader()
    reader.setpoint[:] = -7.0
    assert reader.read(SENSOR) == 0
    assert reader.ends.tolist() == [0, 0, len(SENSOR)]
    assert np.all(reader.setpoint == -7.0)  # no setpoint read: the last one's fields stay


def _corrupt(frame: bytes, at: int) -> bytes:
    return frame[:at] + bytes([frame[at] ^ 0x01]) + frame[at + 1:]


GPS = bytes(common.MAVLink_hil_gps_message(4000, 3, 473977420, 85455940, 488000, 90, 180, 0, 0, 0, 0, 65535,
                                           10).pack(BENCH))
NOT_ONE_STEP = {
    "empty": b"",
    "the setpoint alone": SETPOINTS["every field"],
    "the sensor frame, then the setpoint": SENSOR + SETPOINTS["every field"],
    "a sensor frame and a HIL_GPS": SENSOR + GPS,
    "a HIL_GPS, then a sensor frame": GPS + SENSOR,
    "two sensor frames": SENSOR + flight_frames()[1],
    "two setpoints, then a sensor frame": SETPOINTS["every field"] * 2 + SENSOR,
    "the setpoint's checksum wrong": _corrupt(SETPOINTS["every field"], 20) + SENSOR,
    "the sensor frame's checksum wrong": SETPOINTS["every field"] + _corrupt(SENSOR, 20),
    "a byte missing": (SETPOINTS["every field"] + SENSOR)[:-1],
    "a byte more": SETPOINTS["every field"] + SENSOR + b"\x00",
    "a byte of garbage first": b"\x55" + SETPOINTS["every field"] + SENSOR,
    "an unknown incompatibility flag": SENSOR[:2] + b"\x02" + SENSOR[3:],
    "the ODOMETRY before the setpoint": odometry_frame(4000) + SETPOINTS["every field"] + SENSOR,
    "two ODOMETRY frames": odometry_frame(4000) * 2 + SENSOR,
    "the ODOMETRY alone": odometry_frame(4000),
}


@pytest.mark.parametrize("name", NOT_ONE_STEP)
def test_what_is_not_one_step_is_left_to_the_scanner(name):
    assert StepReader().read(NOT_ONE_STEP[name]) == -1


class ServedBoard:
    """An emulator on a real pty, served one read at a time from the test's thread, and the bench's end of it."""

    def __init__(self, whole_steps: bool, state_source: str) -> None:
        pair = open_pty_pair()
        self.board = EmulatedBoard(Link(SerialTransport(pair.slave_path)), build_config({"state_source": state_source}),
                                   repeat_boot_heartbeat=False)
        pair.release_slave()
        self.bench = pair.master
        self.steps_taken_whole = 0
        self.writes = 0  # the emulator's writes: each turn's answer is one
        write = self.board.link.transport.write

        def counted_write(data: bytes) -> None:
            self.writes += 1
            write(data)

        self.board.link.transport.write = counted_write  # type: ignore[method-assign]
        self.frames_in: list[bytes] = []  # what the link's tap saw of the bench's frames (a run's tlog sees them)
        self.board.link.tap = lambda frames: self.frames_in.extend(f for f in frames if f[6] != BOARD_COMPONENT)
        if whole_steps:
            read = self.board.step_reader.read

            def counted(data: bytes) -> int:
                found = read(data)
                self.steps_taken_whole += found >= 0
                return found

            self.board.step_reader.read = counted  # type: ignore[method-assign]
        else:
            self.board.link.whole_frame_reader = None

    def exchange(self, write: bytes) -> bytes:
        """`write` in one piece, one turn of the emulator's loop, and every byte it answered (one write, or none)."""
        self.bench.write(write)
        self.board.serve_once(1.0)
        answer = b""
        while select.select([self.bench.fd], [], [], 0.002)[0]:
            answer += self.bench.read(0.0)
        return answer

    def close(self) -> None:
        self.board.link.close()
        self.bench.close()


@pytest.mark.parametrize("state_source", ["estimator", "truth"])
def test_an_emulator_taking_whole_steps_answers_byte_for_byte_as_one_reading_every_frame_as_a_message(state_source):
    whole, by_message = ServedBoard(True, state_source), ServedBoard(False, state_source)
    try:
        for k, sensor in enumerate(flight_frames()[:300]):
            setpoint = setpoint_frame(time_boot_ms=4 * k, x=0.01 * k, yaw=0.001 * k)
            truth = odometry_frame(4000 * (k + 1), 0.001 * k) if state_source == "truth" else b""
            write = truth + sensor if k % 3 == 0 else setpoint + truth + sensor  # every third without a setpoint
            before = whole.writes
            assert whole.exchange(write) == by_message.exchange(write), f"step {k}"
            assert whole.writes == by_message.writes
            assert k == 0 or whole.writes == before + 1  # the reply and the streams due, in one write
            if k == 0:  # the origin and the magnetic field, after the first sensor frame: alignment can happen
                assert whole.exchange(GPS) == by_message.exchange(GPS)
        assert whole.steps_taken_whole == 300
        assert whole.frames_in == by_message.frames_in
        assert len(whole.frames_in) == 300 + 200 + 1 + (300 if state_source == "truth" else 0)
        assert whole.board.link.scanner.frames_accepted == by_message.board.link.scanner.frames_accepted
        assert whole.board.link.ids_seen == by_message.board.link.ids_seen
        assert whole.board.estimator.aligned
        assert whole.board.estimator.x.tobytes() == by_message.board.estimator.x.tobytes()
        if state_source == "truth":
            flown_on, read_on = whole.board.truth, by_message.board.truth
            assert flown_on is not None and read_on is not None
            last_sent = [float(np.float32(v)) for v in (0.299, 0.2, -3.0)]  # the last step's, as float32 carries it
            assert flown_on.pos_ned.tolist() == read_on.pos_ned.tolist() == last_sent
        taken, read = whole.board.offboard, by_message.board.offboard
        assert taken.setpoint is not None and read.setpoint is not None
        assert (taken.kind, taken.received_us, taken.yaw) == (read.kind, read.received_us, read.yaw)
        assert taken.setpoint.pos_ned.tolist() == read.setpoint.pos_ned.tolist() == [
            float(np.float32(0.01 * 299)), -2.25, -12.0]
    finally:
        whole.close()
        by_message.close()
