"""One step's frames to the board, in the order its links need: everything on one link (the emulator, a serial
board, PX4's HITL path), or PX4 SITL's lockstep HIL link beside its own command link."""

from __future__ import annotations

import math

import numpy as np

from firmware_interface import hil_codec as codec
from firmware_interface.geodesy import LocalFrame
from firmware_interface.link import Message
from hil.boards.handle import BoardHandle
from hil.boards.target import GroundTruthUse
from hil.loop.senders import Periodic
from hil.loop.step_frames import ODOMETRY_FLAG, SETPOINT_FLAG, StepFrames, pack_only, sense_and_pack, sense_only
from hil.loop.timing import LoopTiming
from hil.scenario.reference import RefSample
from hil.sensors import SensorSuite
from plant_fmu.state import StepOutputs

# The offboard setpoint's period on PX4 SITL's command link: 50 Hz, what an offboard companion streams (MAVSDK
# resends its last setpoint at 20 Hz; PX4 asks for more than 2 Hz). Each one costs PX4 a UDP receive and its
# mavlink receiver's handling, and the bench a send: sent every 250 Hz step, a --px4 hover ran ~6 % slower
# (docs/performance.md, issue 36's fourteenth stop).
SITL_SETPOINT_PERIOD_US = 20_000


class BoardIO:
    """A board with one link: the setpoint goes in the step's one write, ahead of the sensors, and the board
    flies it this step."""

    setpoint_in_frame = True

    def __init__(self, board: BoardHandle, truth_use: GroundTruthUse, frame: LocalFrame, steady_wind_ned: np.ndarray,
                 timing: LoopTiming, sensors: SensorSuite) -> None:
        self.board = board
        self.truth_use = truth_use
        self.frame = frame
        self.steady_wind_ned = steady_wind_ned
        self.timing = timing
        self.ground_station_lost = False  # the relay's traffic is dropped both ways (a ground-station loss)
        self.sensors = sensors
        self.step = StepFrames(sensors.has_faults)
        self._floats, self._ints = sensors.buffers
        self._flags = ODOMETRY_FLAG if truth_use == "to_fly" else 0
        self._lat_lon_alt, self._air_ned = np.zeros(3), np.zeros(3)  # the ground truth's, made in place

    def send_step(self, t_us: int, reference: RefSample | None, offset_ned: np.ndarray | None, truth: StepOutputs,
                  fault_time_s: float) -> tuple[codec.SensorReadings, codec.GpsFix | None]:
        """This step's frame out first, in one write; then what may overlap the board's computation. Returns the
        step's readings."""
        session = self.board.hil_session
        session.link.begin_batch()
        session.begin_step(t_us)
        self._pack_and_send(t_us, reference, offset_ned, truth, fault_time_s)
        session.link.flush()
        self.timing.lap("sensors_and_send")
        self._after_frame(t_us, reference, offset_ned, truth)
        if self.board.gcs is not None:
            self._relay_gcs()
        self.timing.lap("command_link_and_relay")
        return codec.readings_of_row(self.step.row)

    def _pack_and_send(self, t_us: int, reference: RefSample | None, offset_ned: np.ndarray | None,
                       truth: StepOutputs, fault_time_s: float) -> None:
        """The sensor models and the step's frames (`step_frames`), into the link's write."""
        step, link = self.step, self.board.hil_session.link
        flags = self._flags
        if reference is not None and self.setpoint_in_frame:
            flags |= SETPOINT_FLAG
            setpoint = step.setpoint  # filled in place: no array made a step
            np.add(reference.pos_ned, offset_ned if offset_ned is not None else 0.0, out=setpoint[0:3])
            setpoint[3:6] = reference.vel_ned
            setpoint[6:9] = reference.acc_ned
            setpoint[9] = reference.yaw
            step.target[0], step.target[1] = self.board.command_session.target()
        link.encoder.numbering_into(step.link)
        state = truth.pos_ned, truth.vel_ned, truth.q_wxyz, truth.rates_frd
        self.sensors.refill()
        if step.has_faults:  # the models, the faults on their readings, then the frames
            sense_only(self._floats, self._ints, t_us, *state, truth.specific_force_frd, step.row)
            self.sensors.row[:] = step.row
            self.sensors.apply_faults(fault_time_s)
            step.row[:] = self.sensors.row
            count = pack_only(step.row, *state, flags, step.setpoint, step.target, step.frames, step.ends, step.link)
        else:
            count = sense_and_pack(self._floats, self._ints, t_us, *state, truth.specific_force_frd, step.row, flags,
                                   step.setpoint, step.target, step.frames, step.ends, step.link)
        link.send_frames(step.frames, step.ends, count)

    def _after_frame(self, t_us: int, reference: RefSample | None, offset_ned: np.ndarray | None,
                     truth: StepOutputs) -> None:
        if self.truth_use == "for_log":
            self._send_ground_truth_ahead(t_us, truth)

    def drain(self) -> None:
        """Read what every link to the board holds now and drop its messages (the board's state keeps them)."""
        for session in self.board.sessions:
            session.poll(0.0)
        self.take_inbox()

    def take_inbox(self) -> list[Message]:
        """This step's messages from every link to the board, taken as they came (decoded later)."""
        return self.board.hil_session.take_inbox()

    def _send_setpoint(self, t_us: int, reference: RefSample, offset_ned: np.ndarray | None) -> None:
        """The reference in the board's own local frame (`offset_ned`, from arming on), on its command link."""
        offset = offset_ned if offset_ned is not None else 0.0
        self.board.command_session.send_setpoint(t_us // 1000, reference.pos_ned + offset, reference.vel_ned,
                                                 reference.acc_ned, reference.yaw)

    def _relay_gcs(self) -> None:
        """When a relay pass is due (`GcsBridge.due`): board -> GCS for what came with the replies since the last
        pass; GCS -> board after this step's HIL frames (neither way in a ground-station loss)."""
        gcs, board = self.board.gcs, self.board
        assert gcs is not None
        if not gcs.due():
            return
        for session in board.sessions:
            frames = session.take_relayed()
            if frames and not self.ground_station_lost:
                gcs.to_gcs(frames)
        for frame in gcs.from_gcs():
            if not self.ground_station_lost:
                board.command_session.link.send_frame(frame)

    def _send_ground_truth_ahead(self, t_us: int, truth: StepOutputs) -> None:
        """The true state as HIL_STATE_QUATERNION carries it (geodetic position), for PX4 SITL's log: packed from
        the plant's outputs in place (made into a `GroundTruth` first, it cost ~7 µs more of a --px4 step)."""
        pos, lat_lon_alt, air_ned = truth.pos_ned, self._lat_lon_alt, self._air_ned
        lat_lon_alt[:] = self.frame.to_geodetic(float(pos[0]), float(pos[1]), float(pos[2]))
        np.subtract(truth.vel_ned, self.steady_wind_ned, out=air_ned)
        self.board.hil_session.send_ground_truth_ahead(t_us, truth.q_wxyz, truth.rates_frd, lat_lon_alt, truth.vel_ned,
                                                       truth.specific_force_frd, math.sqrt(air_ned.dot(air_ned)))


class SplitBoardIO(BoardIO):
    """PX4 SITL: its commands, ACKs and states come on a UDP link its own thread serves, so no step of ours is the
    one they belong to. The setpoint goes there after the sensor frame (it never had a defined order against it),
    at an offboard companion's rate (`SITL_SETPOINT_PERIOD_US`)."""

    setpoint_in_frame = False

    def __init__(self, board: BoardHandle, truth_use: GroundTruthUse, frame: LocalFrame, steady_wind_ned: np.ndarray,
                 timing: LoopTiming, sensors: SensorSuite) -> None:
        super().__init__(board, truth_use, frame, steady_wind_ned, timing, sensors)
        self.setpoints = Periodic(SITL_SETPOINT_PERIOD_US)

    def _after_frame(self, t_us: int, reference: RefSample | None, offset_ned: np.ndarray | None,
                     truth: StepOutputs) -> None:
        super()._after_frame(t_us, reference, offset_ned, truth)
        commands = self.board.command_session
        if reference is not None and self.setpoints.due(t_us):
            self._send_setpoint(t_us, reference, offset_ned)
        commands.poll(0.0)
        commands.service(t_us * 1e-6 if self.board.hil_session.lockstep else None)

    def take_inbox(self) -> list[Message]:
        return self.board.hil_session.take_inbox() + self.board.command_session.take_inbox()


def board_io(board: BoardHandle, truth_use: GroundTruthUse, frame: LocalFrame, steady_wind_ned: np.ndarray,
             timing: LoopTiming, sensors: SensorSuite) -> BoardIO:
    kind = SplitBoardIO if board.own_command_link else BoardIO
    return kind(board, truth_use, frame, steady_wind_ned, timing, sensors)
