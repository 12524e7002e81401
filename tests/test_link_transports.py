"""Real bytes through a real pty, TCP and UDP on loopback; a peer that goes away is LinkLost."""

from __future__ import annotations

import os
import threading
import time

import fastcrc
import pytest

from firmware_interface.link import (
    Link,
    LinkError,
    LinkLost,
    open_pty_pair,
    parse_connection,
)
from firmware_interface.link.transports import (
    FdTransport,
    SerialTransport,
    TcpClientTransport,
    TcpServerTransport,
    UdpTransport,
)


def drain(link: Link, count: int, timeout_s: float = 5.0) -> list:
    got: list = []
    deadline = time.monotonic() + timeout_s
    while len(got) < count and time.monotonic() < deadline:
        got += link.receive(0.05)
    return got


def heartbeat(link: Link, i: int) -> None:
    link.send("HEARTBEAT", type=2, autopilot=12, base_mode=i % 256, custom_mode=i, system_status=4,
              mavlink_version=3)


def test_pty_pair_carries_frames_both_ways_and_master_sees_the_board_close():
    pair = open_pty_pair()
    bench = Link(pair.master)
    board = Link(SerialTransport(pair.slave_path), system_id=1, component_id=1)
    pair.release_slave()
    for i in range(300):
        heartbeat(board, i)
    got = drain(bench, 300)
    assert [m.custom_mode for m in got] == list(range(300))
    for i in range(300):
        heartbeat(bench, i)
    assert len(drain(board, 300)) == 300
    board.close()
    with pytest.raises(LinkLost, match="closed"):
        for _ in range(20):
            bench.receive(0.05)
    bench.close()


def test_serial_side_sees_the_bench_close_the_pty():
    pair = open_pty_pair()
    board = Link(SerialTransport(pair.slave_path))
    pair.release_slave()
    pair.master.close()
    with pytest.raises(LinkLost):
        for _ in range(20):
            board.receive(0.05)
    board.close()


def test_tcp_server_accepts_px4_style_client_and_reports_reset_mid_stream():
    server = TcpServerTransport("127.0.0.1", 0)
    bench = Link(server)
    client = Link(TcpClientTransport("127.0.0.1", server.port))
    assert server.accept(2.0)
    for i in range(200):
        heartbeat(client, i)
    assert len(drain(bench, 200)) == 200
    heartbeat(bench, 1)
    assert len(drain(client, 1)) == 1
    client.transport.write(b"\xfd\x09\x00")  # half a frame, then the peer goes away
    client.close()
    with pytest.raises(LinkLost, match="peer closed"):
        for _ in range(40):
            bench.receive(0.05)
    bench.close()


def test_udp_in_answers_the_last_sender():
    listener = UdpTransport("127.0.0.1", 0, listen=True)
    bench = Link(listener)
    peer = Link(UdpTransport("127.0.0.1", listener.port, listen=False))
    heartbeat(peer, 7)
    assert drain(bench, 1)[0].custom_mode == 7
    heartbeat(bench, 9)
    assert drain(peer, 1)[0].custom_mode == 9
    bench.close()
    peer.close()


def test_receive_returns_within_the_callers_timeout_when_nothing_arrives():
    pair = open_pty_pair()
    bench = Link(pair.master)
    start = time.monotonic()
    assert bench.receive(0.1) == []
    assert time.monotonic() - start < 1.0  # generous: only "does not block", not a timing benchmark
    pair.release_slave()
    bench.close()


def test_a_fake_start_does_not_stall_frames_on_a_live_link():
    pair = open_pty_pair()
    bench = Link(pair.master)
    board = Link(SerialTransport(pair.slave_path))
    pair.release_slave()
    board.transport.write(b"\xfd\x41\x00\x00\x00\x01\x01\x6b\x00\x00")  # HIL_SENSOR header, LEN 65, no body
    heartbeat(board, 42)
    got = drain(bench, 1, timeout_s=2.0)
    assert got and got[0].custom_mode == 42
    board.close()
    bench.close()


@pytest.mark.parametrize(
    ("text", "kind", "address", "number"),
    [
        ("/dev/ttyACM0", "serial", "/dev/ttyACM0", 921600),
        ("serial:/dev/ttyUSB1:57600", "serial", "/dev/ttyUSB1", 57600),
        ("tcpin:0.0.0.0:4560", "tcpin", "0.0.0.0", 4560),
        ("tcp:127.0.0.1:5760", "tcp", "127.0.0.1", 5760),
        ("udpin:0.0.0.0:14560", "udpin", "0.0.0.0", 14560),
        ("udpout:127.0.0.1:14550", "udpout", "127.0.0.1", 14550),
        ("udp:0.0.0.0:14550", "udpin", "0.0.0.0", 14550),  # mavutil's listening form
        ("/dev/ttyACM0,57600", "serial", "/dev/ttyACM0", 57600),  # MAVProxy's device,baud
    ],
)
def test_connection_strings_px4_users_know(text, kind, address, number):
    c = parse_connection(text)
    assert (c.kind, c.address, c.number) == (kind, address, number)


@pytest.mark.parametrize("text", ["COM3", "tcpin:4560", "http://x:1", "udp:1.2.3.4", "tcp:host:99999"])
def test_other_connection_strings_are_refused_in_one_line(text):
    with pytest.raises(LinkError) as err:
        parse_connection(text)
    assert "\n" not in str(err.value) and text in str(err.value)


def test_opening_a_missing_serial_port_is_a_clear_error():
    with pytest.raises(LinkError, match="no device /dev/does-not-exist: is the board plugged in"):
        SerialTransport("/dev/does-not-exist")


def test_pty_slave_is_raw_so_binary_is_not_echoed():
    pair = open_pty_pair()
    bench = Link(pair.master)
    os.write(pair.slave_fd, b"")  # the slave is open; nothing is echoed back to the master
    heartbeat(bench, 1)
    got = []
    def reader() -> None:
        got.extend(os.read(pair.slave_fd, 64) for _ in range(1))
    t = threading.Thread(target=reader)
    t.start()
    t.join(2.0)
    assert got and got[0][0] == 0xFD and len(got[0]) == 21
    assert bench.receive(0.1) == []  # no echo of our own frame
    pair.release_slave()
    bench.close()


def test_common_messages_pymavlink_lacks_are_passed_through_whole_not_counted_as_errors():
    """LINK_NODE_STATUS (id 8), which PX4 sends and pymavlink 2.4 cannot decode: a v2 frame built by hand
    with its CRC_EXTRA (117, from MAVLink's common.xml) is accepted, kept whole, and no error."""
    payload = bytes(range(36))
    header = bytes([36, 0, 0, 7, 1, 1, 8, 0, 0])
    crc = fastcrc.crc16.mcrf4xx(header + payload + bytes([117]))
    frame = bytes([0xFD]) + header + payload + crc.to_bytes(2, "little")
    read_fd, write_fd = os.pipe()
    link = Link(FdTransport(read_fd, "pipe"))
    try:
        os.write(write_fd, frame + frame[:-1] + bytes([frame[-1] ^ 1]))  # a good one, then one with a bad CRC
        assert link.receive(0.2) == []
        assert link.passthrough == [frame]
        counters = link.counters
        assert counters["passed_through"] == 1 and counters["unknown_id"] == 0 and counters["decode_errors"] == 0
        assert counters["bad_crc"] == 1
    finally:
        link.close()
        os.close(write_fd)
