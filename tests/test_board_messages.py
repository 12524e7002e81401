"""The board's messages decoded for the recording: fields and units per the MAVLink common dialect, the
controller's values named by the name DEBUG_FLOAT_ARRAY carries (cut to its 10 characters)."""

from __future__ import annotations

import math

import pytest
from pymavlink.dialects.v20 import common

from firmware_interface.emulator.control.registry import INTERNAL_KEYS
from hil.loop.board_messages import decode_board_message


def wire(msg):
    """The message through real MAVLink bytes, as it arrives from a board."""
    mav = common.MAVLink(None, srcSystem=1, srcComponent=1)
    return mav.parse_char(msg.pack(mav))


def test_attitude_target_carries_its_quaternion_and_its_euler_angles():
    half = math.radians(90) / 2  # 90° of yaw: q = (cos 45°, 0, 0, sin 45°)
    msg = wire(common.MAVLink_attitude_target_message(0, 0, [math.cos(half), 0, 0, math.sin(half)], 0, 0, 0, 0.55))
    kind, payload = decode_board_message(msg)
    assert kind == "ATTITUDE_TARGET" and payload["thrust"] == pytest.approx(0.55)
    assert payload["rpy"] == pytest.approx([0.0, 0.0, math.pi / 2], abs=1e-6)  # float32 on the wire


def test_debug_float_array_values_are_named_after_the_controller_even_when_its_name_was_cut():
    keys = INTERNAL_KEYS["backstepping"]
    data = [float(i + 1) for i in range(len(keys))] + [0.0] * (58 - len(keys))
    msg = wire(common.MAVLink_debug_float_array_message(0, b"backsteppi", 1, data))
    kind, payload = decode_board_message(msg)
    assert kind == "DEBUG_FLOAT_ARRAY" and payload["values"] == {k: float(i + 1) for i, k in enumerate(keys)}
    unknown = wire(common.MAVLink_debug_float_array_message(0, b"other", 1, [0.0, 2.5] + [0.0] * 56))
    assert decode_board_message(unknown)[1]["values"] == {"v1": 2.5}  # unnamed: the non-zero slots by index


def test_heartbeat_armed_flag_and_px4_mode_and_what_is_not_recorded():
    msg = wire(common.MAVLink_heartbeat_message(2, 12, 128 | 1, 6 << 16, 4, 3))
    assert decode_board_message(msg) == ("HEARTBEAT", {"armed": True, "custom_mode": 6 << 16, "system_status": 4})
    assert decode_board_message(wire(common.MAVLink_system_time_message(0, 0))) is None


def test_local_position_and_attitude_in_si():
    pos = wire(common.MAVLink_local_position_ned_message(0, 1.0, -2.0, -3.0, 0.1, 0.2, -0.3))
    assert decode_board_message(pos) == ("LOCAL_POSITION_NED", {"pos_ned": [1.0, -2.0, -3.0],
                                                                "vel_ned": pytest.approx([0.1, 0.2, -0.3])})
    att = wire(common.MAVLink_attitude_message(0, 0.1, -0.2, 3.0, 0, 0, 0))
    assert decode_board_message(att)[1]["rpy"] == pytest.approx([0.1, -0.2, 3.0])
