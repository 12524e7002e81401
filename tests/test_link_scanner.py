"""The frame scanner on noisy streams: every untouched frame recovered, in order; no bad frame ever out."""

from __future__ import annotations

import random

from hypothesis import given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import common

from firmware_interface.link import FrameScanner, Reject
from firmware_interface.link.dialect import SPECS
from tests.support.noisy_stream import clean_frame, make_noisy_stream


def _crc_ok(frame: bytes) -> bool:
    """Independent check with pymavlink's decoder (strict mode raises on a bad CRC)."""
    common.MAVLink(None).decode(bytearray(frame))
    return True


def test_noisy_stream_in_one_piece_recovers_every_intact_frame_and_counts_each_fault():
    stream = make_noisy_stream(4000, seed=7)
    scanner = FrameScanner()
    frames = scanner.feed(stream.data, 0.0)
    assert frames == stream.frames
    for reason in ("bad_length", "unknown_id", "bad_flags", "bad_crc", "garbage_bytes"):
        assert scanner.counts[reason] == stream.injected[reason], reason
    assert scanner.counts["timeout"] == 0 and scanner.counts["truncated"] == 0
    assert sum(stream.injected.values()) > 1000


def test_noisy_stream_in_random_chunks_gives_the_same_frames():
    stream = make_noisy_stream(3000, seed=11)
    rng = random.Random(3)
    scanner = FrameScanner()
    frames: list[bytes] = []
    pos = 0
    while pos < len(stream.data):
        n = rng.randint(1, 300)
        frames += scanner.feed(stream.data[pos : pos + n], 0.0)
        pos += n
    assert frames == stream.frames
    # A truncated frame is rejected by its CRC once its LEN is covered, or earlier as
    # "truncated" when a complete frame already stands behind it in the buffer.
    assert scanner.counts["bad_crc"] + scanner.counts["truncated"] == stream.injected["bad_crc"]
    accepted = sum(len(f) for f in frames)
    rejected = sum(scanner.counts[r] for r in Reject if r is not Reject.GARBAGE)
    assert accepted + rejected + scanner.counts["garbage_bytes"] + scanner.pending_bytes == len(stream.data)


def test_fake_ff_length_does_not_swallow_the_frames_behind_it():
    """docs/px4_protocol.md §2.2: pymavlink returns nothing at all for `FD FF 00` + 6 frames."""
    rng = random.Random(1)
    mav = common.MAVLink(None)
    good = [clean_frame(rng, mav) for _ in range(6)]
    scanner = FrameScanner()
    assert scanner.feed(b"\xfd\xff\x00" + b"".join(good), 0.0) == good


def test_partial_frame_times_out_and_later_frames_still_parse():
    rng = random.Random(2)
    mav = common.MAVLink(None)
    frame = clean_frame(rng, mav)
    scanner = FrameScanner(partial_timeout_s=0.02)
    assert scanner.feed(frame[:15], now_s=1.000) == []
    assert scanner.poll(now_s=1.010) == [] and scanner.counts["timeout"] == 0
    assert scanner.poll(now_s=1.031) == []
    assert scanner.counts["timeout"] == 1
    assert scanner.pending_bytes == 0
    nxt = clean_frame(rng, mav)
    assert scanner.feed(nxt, now_s=1.04) == [nxt]


def test_v1_frames_and_signed_v2_frames_are_accepted():
    mav = common.MAVLink(None, srcSystem=3, srcComponent=1)
    v1 = bytes(common.MAVLink_heartbeat_message(2, 12, 0, 0, 0, 3).pack(mav, force_mavlink1=True))
    signer = common.MAVLink(None, srcSystem=3, srcComponent=1)
    signer.signing.secret_key = bytes(range(32))
    signer.signing.sign_outgoing = True
    signed = bytes(common.MAVLink_hil_actuator_controls_message(5, [0.5] * 16, 129, 1).pack(signer))
    plain = bytes(common.MAVLink_heartbeat_message(2, 12, 0, 0, 0, 3).pack(mav))
    assert v1[0] == 0xFE and signed[2] & 0x01 and len(signed) == 93 + 13
    scanner = FrameScanner()
    assert scanner.feed(v1 + signed + plain, 0.0) == [v1, signed, plain]
    assert sum(scanner.counts.values()) == 0


def test_length_above_full_payload_and_zero_length_are_rejected():
    # a HEARTBEAT (full payload 9) header claiming 10 bytes, and a LEN of 0
    assert SPECS[0].full_payload == 9
    scanner = FrameScanner()
    scanner.feed(bytes([0xFD, 10, 0, 0, 0, 1, 1, 0, 0, 0]) + bytes([0xFD, 0]) + bytes(20), 0.0)
    assert scanner.counts["bad_length"] == 2


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=600))
def test_arbitrary_bytes_never_raise_and_never_yield_a_corrupt_frame(data):
    scanner = FrameScanner()
    for frame in scanner.feed(data, 0.0) + scanner.poll(1.0):
        assert _crc_ok(frame)


@settings(max_examples=200, deadline=None)
@given(st.binary(max_size=200), st.binary(max_size=200), st.integers(0, 10**6))
def test_frames_embedded_in_arbitrary_bytes_are_recovered(before, after, seed):
    rng = random.Random(seed)
    mav = common.MAVLink(None)
    frames = [clean_frame(rng, mav) for _ in range(3)]
    scanner = FrameScanner()
    out = scanner.feed(before + frames[0] + frames[1] + after + frames[2], 0.0)
    for frame in out:
        assert _crc_ok(frame)
    it = iter(out)
    assert all(any(f == o for o in it) for f in frames), "every embedded frame is recovered, in order"


def test_a_slow_serial_line_byte_by_byte_loses_no_intact_frame():
    """At 38,400 baud (10 bits a byte, 8N1) a long frame takes ~60 ms to arrive: the partial-frame wait
    follows the line's rate, so every frame delivered byte by byte at that rate is accepted."""
    from firmware_interface.link.scanner import partial_timeout_for

    baud = 38_400
    rng = random.Random(5)
    mav = common.MAVLink(None)
    frames = [clean_frame(rng, mav) for _ in range(300)]
    assert max(len(f) for f in frames) * 10 / baud > 0.02  # longer than the old fixed 20 ms wait
    scanner = FrameScanner(partial_timeout_for(baud))
    now, out = 0.0, []
    for byte in b"".join(frames):
        now += 10 / baud
        out += scanner.feed(bytes([byte]), now)
    assert out == frames and scanner.counts["timeout"] == 0
    assert partial_timeout_for(None) == 0.02 and partial_timeout_for(921_600) == 0.02
