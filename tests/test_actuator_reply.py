"""A board's HIL_ACTUATOR_CONTROLS read from its bytes in one compiled call: against frames pymavlink packs (MAVLink 2,
trimmed, signed, MAVLink 1), PX4's output ranges, the frames a reply is not, and a session reading replies over a
real pty both alone in a read and among other frames."""

from __future__ import annotations

import math
import os
import struct

import pytest
from pymavlink.dialects.v10 import common as common_v1
from pymavlink.dialects.v20 import common

from firmware_interface.actuator_reply import ActuatorReader
from firmware_interface.board import SIMULATED, BoardSession
from firmware_interface.link import Link, open_pty_pair


def reply_frame(t_us: int, controls: list[float], mode: int = 129, flags: int = 1, system: int = 1,
                dialect: object = common, secret: bytes | None = None) -> bytes:
    """HIL_ACTUATOR_CONTROLS as pymavlink packs it (16 controls, the rest zero)."""
    mav = dialect.MAVLink(None, srcSystem=system, srcComponent=1)  # type: ignore[attr-defined]
    if secret is not None:
        mav.signing.secret_key, mav.signing.sign_outgoing, mav.signing.link_id = secret, True, 0
    message = dialect.MAVLink_hil_actuator_controls_message(  # type: ignore[attr-defined]
        t_us, controls + [0.0] * (16 - len(controls)), mode, flags)
    return bytes(message.pack(mav))


def f32(value: float) -> float:
    """`value` as it crosses the wire: a float32."""
    return struct.unpack("<f", struct.pack("<f", value))[0]


def test_a_quad_x_reply_reads_as_pymavlink_decodes_it_with_motors_clipped_to_0_1():
    frame = reply_frame(123_456_789, [0.61, 0.62, 0.63, 1.4])
    decoded = common.MAVLink(None).decode(bytearray(frame))
    out = ActuatorReader().read(frame)
    assert out is not None and out.t_us == decoded.time_usec == 123_456_789
    assert out.motors == (decoded.controls[0], decoded.controls[1], decoded.controls[2], 1.0)
    assert out.motors[:3] == (f32(0.61), f32(0.62), f32(0.63))
    assert out.armed and out.lockstep and (out.mode, out.flags) == (129, 1)
    disarmed = ActuatorReader().read(reply_frame(1, [], mode=1, flags=0))
    assert disarmed is not None and not disarmed.armed and not disarmed.lockstep and disarmed.motors == (0.0,) * 4


def test_outside_px4s_ranges_values_are_clipped_and_non_numbers_stop_the_motor():
    """PX4's outputs: 0..1 for a motor, −1..1 for a reversible one; NaN and ±inf (a broken board) command 0."""
    frame = reply_frame(7, [-0.3, math.nan, math.inf, -math.inf, 1.7, -1.5])
    out, reversible = ActuatorReader(6).read(frame), ActuatorReader(6, reversible=True).read(frame)
    assert out is not None and out.motors == (0.0, 0.0, 0.0, 0.0, 1.0, 0.0)
    assert reversible is not None and reversible.motors == (f32(-0.3), 0.0, 0.0, 0.0, 1.0, -1.0)


def test_a_trimmed_a_signed_and_a_mavlink_1_reply_read_alike():
    """MAVLink 2 trims a payload's trailing zeros (mode 0: the last byte goes); a signed frame carries 13 bytes
    after its checksum; a MAVLink 1 frame has a 6-byte header."""
    controls = [0.25, 0.5, 0.75, 1.0]
    trimmed = reply_frame(42, controls, mode=0)
    assert trimmed[1] < common.MAVLink_hil_actuator_controls_message.unpacker.size  # the sender trimmed it
    frames = {"trimmed": trimmed, "signed": reply_frame(42, controls, mode=0, secret=bytes(range(32))),
              "MAVLink 1": reply_frame(42, controls, mode=0, dialect=common_v1)}
    assert frames["signed"][2] & 0x01 and frames["MAVLink 1"][0] == 0xFE
    for kind, frame in frames.items():
        out = ActuatorReader().read(frame)
        assert out is not None, kind
        assert (out.t_us, out.motors, out.mode, out.flags, out.armed) == (42, tuple(controls), 0, 1, False), kind


def test_what_is_not_one_whole_valid_reply_is_left_to_the_scanner():
    frame = reply_frame(5, [0.5] * 4)
    corrupted = bytearray(frame)
    corrupted[20] ^= 0x01
    heartbeat = bytes(common.MAVLink_heartbeat_message(2, 12, 0, 0, 0, 3).pack(common.MAVLink(None)))
    reader = ActuatorReader()
    for kind, data in (("a bad checksum", bytes(corrupted)), ("another message", heartbeat),
                       ("two replies", frame + frame), ("a reply and a byte", frame + b"\x00"),
                       ("half a reply", frame[:50]), ("a reply after a byte", b"\x55" + frame), ("nothing", b""),
                       ("an unknown incompatibility flag", frame[:2] + b"\x02" + frame[3:])):
        assert reader.read(data) is None, kind
    assert reader.read(frame) is not None


@pytest.fixture
def session_and_board():
    """A session on a pty's master; the board's end is the raw slave descriptor the test writes frames to."""
    pair = open_pty_pair()
    tapped: list[bytes] = []
    session = BoardSession(Link(pair.master, tap=tapped.extend), SIMULATED, watchdog_s=2.0)
    yield session, pair.slave_fd, tapped
    session.link.close()
    pair.release_slave()


def test_a_session_reads_a_reply_alone_in_a_read_as_it_reads_one_among_other_frames(session_and_board):
    session, board_fd, tapped = session_and_board
    heartbeat = bytes(common.MAVLink_heartbeat_message(2, 12, 32, 0, 3, 3).pack(common.MAVLink(None, srcSystem=1)))
    os.write(board_fd, heartbeat)
    session.wait_heartbeat(2.0)
    accepted = session.link.scanner.frames_accepted
    alone, among = reply_frame(4000, [0.1, 0.2, 0.3, 0.4]), reply_frame(8000, [0.1, 0.2, 0.3, 0.4])
    for t_us, write in ((4000, alone), (8000, heartbeat + among)):
        session.begin_step(t_us)
        tapped.clear()
        os.write(board_fd, write)
        out = session.await_reply()
        assert out is not None and out.t_us == t_us and session.lockstep
        assert out.motors == (f32(0.1), f32(0.2), f32(0.3), f32(0.4))
        assert tapped[-1] == write[-len(alone):]  # the tlog sees the reply, whichever way it was read
    assert session.link.scanner.frames_accepted == accepted + 3
    assert common.MAVLINK_MSG_ID_HIL_ACTUATOR_CONTROLS in session.link.ids_seen
    assert "HIL_ACTUATOR_CONTROLS" not in session.report.latest  # the replies are `actuators`
    assert {message.get_type() for message in session.take_inbox()} == {"HEARTBEAT"}


def test_a_reply_from_another_system_is_not_the_boards(session_and_board):
    """Once the board is known by its heartbeat, another system's HIL_ACTUATOR_CONTROLS drives nothing."""
    session, board_fd, _ = session_and_board
    os.write(board_fd, bytes(common.MAVLink_heartbeat_message(2, 12, 32, 0, 3, 3).pack(
        common.MAVLink(None, srcSystem=1))))
    session.wait_heartbeat(2.0)
    os.write(board_fd, reply_frame(4000, [0.9] * 4, system=7))
    session.poll(0.2)
    assert session.actuators is None and session.link.scanner.frames_accepted == 2
