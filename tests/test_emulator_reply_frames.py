"""The emulator's compiled reply (firmware_interface/emulator/reply_frames.py): the frames equal pymavlink's own
`pack()` of the messages built from the same values in MAVLink's units, numbered one after the other."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from pymavlink.dialects.v20 import common

from firmware_interface.emulator.geometry import euler_to_quat
from firmware_interface.emulator.reply_frames import (
    ARMED,
    CONTROL_STREAMS,
    GLOBAL_POSITION,
    LOCKSTEP,
    STATE_STREAMS,
    ReplyBuffers,
    pack_reply,
)
from firmware_interface.geodesy import LocalFrame

SYSTEM, COMPONENT = 1, 1
ORIGIN = LocalFrame(47.397742, 8.545594, 488.0)


def frames_of(reply: ReplyBuffers, count: int) -> list[bytes]:
    bounds = [0, *reply.ends[:count].tolist()]
    return [reply.frames[a:b].tobytes() for a, b in itertools.pairwise(bounds)]


def pymavlink_frame(message, seq: int) -> bytes:
    mav = common.MAVLink(None, srcSystem=SYSTEM, srcComponent=COMPONENT)
    mav.seq = seq % 256
    return bytes(message.pack(mav))


def flown(rng: np.random.Generator, flags: int, seq: int, motors: np.ndarray, home_d: float = math.nan,
          scale: float = 1.0):
    """pack_reply's frames for random values, and the values."""
    reply = ReplyBuffers("backstepping")
    reply.link[:] = (seq, SYSTEM, COMPONENT)
    reply.origin[:] = ORIGIN.constants
    reply.home_d = home_d
    reply.eta_cmd[:] = rng.uniform(-0.6, 0.6, 3)
    reply.thrust = float(rng.uniform(0, 1))
    reply.debug[:7] = rng.normal(0, 3, 7)
    values = {name: rng.normal(0, scale, 3) for name in ("pos_ned", "vel_ned", "rates_frd")}
    values["eta"] = rng.uniform(-math.pi, math.pi, 3)
    t_us, boot_ms = int(rng.integers(10**6, 10**9)), int(rng.integers(0, 10**6))
    count = pack_reply(reply.frames, reply.ends, reply.link, flags, t_us, boot_ms, values["pos_ned"],
                       values["vel_ned"], values["eta"], values["rates_frd"], reply.origin, reply.home_d, reply.eta_cmd,
                       reply.thrust, reply.debug, reply.debug_name, motors)
    return frames_of(reply, count), reply, values, t_us, boot_ms


def expected_frames(reply: ReplyBuffers, values: dict, t_us: int, boot_ms: int, flags: int, motors: np.ndarray,
                    seq: int) -> list[bytes]:
    """The same step's messages built by pymavlink from the values, converted to MAVLink's units here."""
    pos, vel, eta, rates = (values[k].tolist() for k in ("pos_ned", "vel_ned", "eta", "rates_frd"))
    messages = []
    if flags & STATE_STREAMS:
        messages += [common.MAVLink_attitude_message(boot_ms, *eta, *rates),
                     common.MAVLink_local_position_ned_message(boot_ms, *pos, *vel)]
        if flags & GLOBAL_POSITION:
            lat, lon, alt = ORIGIN.to_geodetic(*pos)
            relative = -pos[2] if math.isnan(reply.home_d) else reply.home_d - pos[2]
            messages.append(common.MAVLink_global_position_int_message(
                boot_ms, round(lat * 1e7), round(lon * 1e7), round(alt * 1000), round(relative * 1000),
                *(round(v * 100) for v in vel), round(math.degrees(eta[2]) % 360 * 100)))
        if flags & CONTROL_STREAMS:
            q = euler_to_quat(*reply.eta_cmd.tolist())
            messages += [common.MAVLink_attitude_target_message(boot_ms, 0, q.tolist(), 0.0, 0.0, 0.0, reply.thrust),
                         common.MAVLink_debug_float_array_message(t_us, b"backsteppi", 1, reply.debug.tolist())]
    armed = bool(flags & ARMED)
    controls = [float(m) if armed else 0.0 for m in motors] + [0.0] * (16 - len(motors))
    messages.append(common.MAVLink_hil_actuator_controls_message(
        t_us, controls, 1 | 32 | (128 if armed else 0), 1 if flags & LOCKSTEP else 0))
    return [pymavlink_frame(m, seq + k) for k, m in enumerate(messages)]


@pytest.mark.parametrize("flags", [ARMED | LOCKSTEP, 0, STATE_STREAMS | LOCKSTEP,
                                   STATE_STREAMS | GLOBAL_POSITION | ARMED,
                                   STATE_STREAMS | GLOBAL_POSITION | CONTROL_STREAMS | ARMED | LOCKSTEP])
def test_the_reply_equals_pymavlinks_frames_of_the_same_values(flags):
    rng = np.random.default_rng(flags)
    for seq, home_d in ((0, math.nan), (253, -3.5), (120, 0.25)):  # 253: the numbering wraps inside the step
        motors = rng.uniform(0, 1, 4)
        ours, reply, values, t_us, boot_ms = flown(rng, flags, seq, motors, home_d)
        assert ours == expected_frames(reply, values, t_us, boot_ms, flags, motors, seq)


def test_a_hexa_reply_carries_six_motors_and_a_disarmed_one_none():
    rng = np.random.default_rng(6)
    motors = np.array((0.1, 0.2, 0.3, 0.4, 0.5, 0.6))
    (armed,), *_ = flown(rng, ARMED, 7, motors)
    (disarmed,), *_ = flown(rng, 0, 7, motors)
    read = common.MAVLink(None)
    on, off = read.decode(bytearray(armed)), read.decode(bytearray(disarmed))
    assert on.controls[:7] == pytest.approx([0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.0]) and on.mode & 128
    assert off.controls == [0.0] * 16 and off.mode == 1 | 32 and off.flags == 0


def test_a_velocity_beyond_global_position_ints_cm_s_takes_the_nearest_value_it_holds():
    """GLOBAL_POSITION_INT carries velocity as int16 cm/s: ±327.67 m/s (pymavlink raises beyond it)."""
    rng = np.random.default_rng(1)
    reply = ReplyBuffers("smarc")
    reply.origin[:] = ORIGIN.constants
    vel = np.array((400.0, -400.0, 12.345))
    count = pack_reply(reply.frames, reply.ends, reply.link, STATE_STREAMS | GLOBAL_POSITION, 0, 0, np.zeros(3), vel,
                       np.zeros(3), np.zeros(3), reply.origin, reply.home_d, reply.eta_cmd, reply.thrust, reply.debug,
                       reply.debug_name, rng.uniform(0, 1, 4))
    position = common.MAVLink(None).decode(bytearray(frames_of(reply, count)[2]))
    assert (position.vx, position.vy, position.vz) == (32767, -32768, 1234)
