"""The frame scanner on noisy streams: every untouched frame recovered, in order; no bad frame ever out."""

from __future__ import annotations

import random

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import common

from firmware_interface.link import FrameScanner, Reject
from firmware_interface.link.dialect import SPECS
from firmware_interface.link.frame_scan import FRAMES_PER_CALL
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
    for read, frames in ((signed + plain, [signed, plain]), (plain + signed + v1, [plain, signed, v1])):
        scanner = FrameScanner()  # reads that begin with a whole frame (the compiled path's), signed ones among them
        assert scanner.feed(read, 0.0) == frames
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


@pytest.mark.parametrize("seed", [7, 11, 23])
def test_the_compiled_clean_frame_path_gives_what_the_general_path_alone_gives(seed):
    """Reads of a noisy stream cut after a good frame (so that the next read begins with one) or anywhere (a
    frame's tail, garbage, a bad frame), fed to a scanner and to one whose every read goes the general way: the
    same frames, the same counts of every rejection, the same bytes left pending."""
    stream = make_noisy_stream(3000, seed=seed)
    rng = random.Random(seed)
    frame_ends, at = [], 0
    for frame in stream.frames:
        at = stream.data.index(frame, at) + len(frame)
        frame_ends.append(at)
    cuts = sorted({*rng.sample(frame_ends, len(frame_ends) // 3), *rng.sample(range(len(stream.data)), 500)})
    fast, general = FrameScanner(), FrameScanner()
    general.feed = general._scan  # type: ignore[method-assign]  # the general path only
    out_fast: list[bytes] = []
    out_general: list[bytes] = []
    for start, end in zip([0, *cuts], [*cuts, len(stream.data)], strict=True):
        out_fast += fast.feed(stream.data[start:end], start * 1e-5)
        out_general += general.feed(stream.data[start:end], start * 1e-5)
    assert out_fast == out_general == stream.frames
    assert fast.counts == general.counts and fast.frames_accepted == general.frames_accepted
    assert fast.pending_bytes == general.pending_bytes


def test_a_read_of_whole_frames_comes_out_whole_and_in_order_beyond_one_calls_ends():
    """More whole frames in one read than `clean_frames` reports at a time, then the first half of a frame: every
    whole frame out, in order, each its own bytes; the half kept for the next read, which completes it."""
    rng = random.Random(2)
    mav = common.MAVLink(None)
    frames = [clean_frame(rng, mav) for _ in range(FRAMES_PER_CALL + 10)]
    last = clean_frame(rng, mav)
    scanner = FrameScanner()
    assert scanner.feed(b"".join(frames) + last[:5], 0.0) == frames
    assert scanner.pending_bytes == 5 and scanner.frames_accepted == len(frames)
    assert scanner.feed(last[5:], 0.0) == [last]
    assert scanner.feed(frames[0], 0.0) == [frames[0]]  # a read of exactly one frame is that frame
