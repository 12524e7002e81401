"""Byte transports under a MAVLink link: serial port, pty, TCP server/client, UDP in/out.

Each has `read(timeout_s)` that returns what arrived (possibly b"") without blocking past
the timeout, `write(data)`, and `close()`. A transport whose other end went away raises
`LinkLost` with the reason.
"""

from __future__ import annotations

import errno
import os
import select
import socket
import statistics
import time
from collections import deque
from collections.abc import Callable
from typing import Protocol

import serial

from firmware_interface.link.errors import LinkError, LinkLost

READ_CHUNK = 65536  # one read takes everything waiting: a board may send several hundred frames a second
UDP_RECEIVE_BUFFER = 1 << 20  # PX4 SITL's MAVLink bursts must wait in the kernel, not be dropped there


class Transport(Protocol):
    name: str

    def read(self, timeout_s: float) -> bytes: ...

    def write(self, data: bytes) -> None: ...

    def close(self) -> None: ...


class SpinWait:
    """Waiting for a reply by polling instead of sleeping, for as long as replies usually take (the median of the
    last WINDOW waits) and never longer than `max_s`; a reply slower than that is waited for asleep, as without it.

    A thread that sleeps in `select` is woken by the kernel when data arrives; on a VM whose idle CPUs halt, that
    costs ~25-45 us, twice per lockstep step. Polling skips the wake-up, but holds a CPU while it waits: worth it
    only with a core to spare (opt-in: `hil run --spin-wait`). Each poll gives the CPU away first (`sched_yield`),
    so whatever else is runnable on that core still runs."""

    WINDOW = 64

    def __init__(self, max_s: float = 500e-6) -> None:
        self.max_s = max_s
        self._waits: deque[float] = deque(maxlen=self.WINDOW)

    def budget_s(self) -> float:
        """How long to poll before sleeping: the recent median wait with a margin, 0 when that is over `max_s`
        (sleeping costs little beside a slow reply) or before there is any history."""
        if len(self._waits) < 8:
            return self.max_s if not self._waits else 0.0
        median = statistics.median(self._waits)
        return 0.0 if median > self.max_s else min(2.0 * median, self.max_s)

    def poll(self, read: Callable[[], bytes], timeout_s: float) -> bytes:
        """`read()` (non-blocking, b"" when nothing is there) until it returns data or the budget is spent."""
        started = time.perf_counter()
        until = started + min(timeout_s, self.budget_s())
        while True:
            data = read()
            if data or time.perf_counter() >= until:
                return data
            os.sched_yield()

    def waited(self, seconds: float) -> None:
        self._waits.append(seconds)


class FdTransport:
    """A raw file descriptor, e.g. the master side of a pty pair the bench created."""

    lost_reason = "the other end of the pty closed"
    write_stall_s = 1.0  # a peer that takes nothing for this long is gone (a full pty or a hung USB CDC port)

    def __init__(self, fd: int, name: str) -> None:
        self.fd = fd
        self.name = name
        self.spin: SpinWait | None = None  # None: wait asleep in select
        os.set_blocking(fd, False)

    def read(self, timeout_s: float) -> bytes:
        if self.spin is not None:
            return _spun(self.spin, self._read_ready, self._read_waiting, timeout_s)
        return self._read_waiting(timeout_s)

    def _read_waiting(self, timeout_s: float) -> bytes:
        ready, _, _ = select.select([self.fd], [], [], max(timeout_s, 0.0))
        return self._read_now() if ready else b""

    def _read_ready(self) -> bytes:
        """What is there now, asked through `select`: a tty set up as pyserial does (VMIN 0) reads 0 bytes both
        when it has nothing and at its end, and only a descriptor `select` calls ready tells the two apart."""
        return self._read_waiting(0.0)

    def _read_now(self) -> bytes:
        try:
            data = os.read(self.fd, READ_CHUNK)
        except BlockingIOError:
            return b""
        except OSError as exc:
            if exc.errno == errno.EIO:
                raise LinkLost(f"{self.name}: {self.lost_reason}") from exc
            raise LinkLost(f"{self.name}: {exc.strerror}") from exc
        if not data:
            raise LinkLost(f"{self.name}: end of stream")
        return data

    def write(self, data: bytes) -> None:
        view = memoryview(data)
        while view:
            try:
                written = os.write(self.fd, view)
            except BlockingIOError:
                _, writable, _ = select.select([], [self.fd], [], self.write_stall_s)
                if not writable:
                    raise LinkLost(f"{self.name}: the peer took no data for {self.write_stall_s:g} s") from None
                continue
            except OSError as exc:
                raise LinkLost(f"{self.name}: {exc.strerror}") from exc
            view = view[written:]

    def close(self) -> None:
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1


def _spun(spin: SpinWait, read_now: Callable[[], bytes], read_waiting: Callable[[float], bytes],
          timeout_s: float) -> bytes:
    """A read that polls for `spin`'s budget first and sleeps in `select` for the rest of `timeout_s` (a look
    without waiting is only a look, and no wait to learn from)."""
    if timeout_s <= 0:
        return read_now()
    started = time.perf_counter()
    data = spin.poll(read_now, timeout_s)
    if not data:
        data = read_waiting(timeout_s - (time.perf_counter() - started))
    if data:
        spin.waited(time.perf_counter() - started)
    return data


class SerialTransport(FdTransport):
    """A serial port (Pixhawk USB CDC, a UART, or a pty slave): 8N1, no flow control.

    pyserial opens, locks and configures the port; reads and writes then go straight to its
    descriptor, because pyserial's own read/write add a second select and timeout bookkeeping
    per call, which the lockstep loop pays twice per step.
    """

    lost_reason = "the port went away (unplugged or closed)"

    def __init__(self, path: str, baud: int = 921600) -> None:
        if not os.path.exists(path):
            raise LinkError(f"no device {path}: is the board plugged in and powered? (`hil ports` lists the ports)")
        try:
            self._port = serial.Serial(path, baud, bytesize=8, parity="N", stopbits=1, timeout=0,
                                       rtscts=False, xonxoff=False, exclusive=True)
        except (serial.SerialException, OSError) as exc:
            raise LinkError(f"cannot open {path}: {exc} (is QGroundControl or another program holding it?)") from exc
        super().__init__(self._port.fileno(), path)
        self.baud = baud

    def close(self) -> None:
        self._port.close()
        self.fd = -1


class _SocketTransport:
    """Shared read/write for a connected stream socket."""

    name: str
    _sock: socket.socket | None
    spin: SpinWait | None = None  # None: wait asleep in select

    def read(self, timeout_s: float) -> bytes:
        if self.spin is not None:
            return _spun(self.spin, self._read_now, self._read_waiting, timeout_s)
        return self._read_waiting(timeout_s)

    def _read_waiting(self, timeout_s: float) -> bytes:
        ready, _, _ = select.select([self._require()], [], [], max(timeout_s, 0.0))
        return self._read_now() if ready else b""

    def _read_now(self) -> bytes:
        try:
            data = self._require().recv(READ_CHUNK, socket.MSG_DONTWAIT)
        except BlockingIOError:
            return b""
        except OSError as exc:
            raise LinkLost(f"{self.name}: {exc.strerror or exc}") from exc
        if not data:
            raise LinkLost(f"{self.name}: the peer closed the connection")
        return data

    def write(self, data: bytes) -> None:
        try:
            self._require().sendall(data)
        except OSError as exc:
            raise LinkLost(f"{self.name}: {exc.strerror or exc}") from exc

    def _require(self) -> socket.socket:
        if self._sock is None:
            raise LinkLost(f"{self.name}: not connected")
        return self._sock

    def close(self) -> None:
        if self._sock is not None:
            self._sock.close()
            self._sock = None


class TcpServerTransport(_SocketTransport):
    """Listens and accepts one client, as a simulator does for PX4 SITL (`tcpin:0.0.0.0:4560`)."""

    def __init__(self, host: str, port: int) -> None:
        self.name = f"tcpin:{host}:{port}"
        self._sock = None
        self._listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self._listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            self._listener.bind((host, port))
        except OSError as exc:
            self._listener.close()
            raise LinkError(f"cannot listen on {host}:{port}: {exc.strerror}") from exc
        self._listener.listen(1)
        self.port = self._listener.getsockname()[1]

    def accept(self, timeout_s: float) -> bool:
        """Wait up to `timeout_s` for the client; True once connected."""
        if self._sock is not None:
            return True
        ready, _, _ = select.select([self._listener], [], [], max(timeout_s, 0.0))
        if not ready:
            return False
        sock, _ = self._listener.accept()
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._sock = sock
        return True

    def read(self, timeout_s: float) -> bytes:
        if self._sock is None:
            self.accept(timeout_s)
            return b""
        return super().read(timeout_s)

    def write(self, data: bytes) -> None:
        if self._sock is not None:  # nothing to send to until the client connects
            super().write(data)

    def close(self) -> None:
        super().close()
        self._listener.close()


class TcpClientTransport(_SocketTransport):
    """Connects to a TCP server (`tcp:HOST:PORT`)."""

    def __init__(self, host: str, port: int, timeout_s: float = 5.0) -> None:
        self.name = f"tcp:{host}:{port}"
        try:
            self._sock = socket.create_connection((host, port), timeout=timeout_s)
        except OSError as exc:
            raise LinkError(f"cannot connect to {host}:{port}: {exc.strerror or exc}") from exc
        self._sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._sock.settimeout(None)


class UdpTransport:
    """`udpin:HOST:PORT` binds and answers the last sender; `udpout:HOST:PORT` sends to that address."""

    def __init__(self, host: str, port: int, listen: bool) -> None:
        self.name = f"{'udpin' if listen else 'udpout'}:{host}:{port}"
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, UDP_RECEIVE_BUFFER)
        self._listen = listen
        self._peer: tuple[str, int] | None = None
        if listen:
            try:
                self._sock.bind((host, port))
            except OSError as exc:
                self._sock.close()
                raise LinkError(f"cannot bind UDP {host}:{port}: {exc.strerror}") from exc
        else:
            self._peer = (host, port)
        self.port = self._sock.getsockname()[1] if listen else port

    def read(self, timeout_s: float) -> bytes:
        """Every datagram waiting (after up to `timeout_s` for the first), joined: a caller that reads once
        per step must not fall behind a board that sends more datagrams than steps."""
        ready, _, _ = select.select([self._sock], [], [], max(timeout_s, 0.0))
        if not ready:
            return b""
        chunks: list[bytes] = []
        while True:
            try:
                data, sender = self._sock.recvfrom(65535, socket.MSG_DONTWAIT)
            except (BlockingIOError, ConnectionRefusedError):  # drained, or an ICMP error for an earlier datagram
                break
            chunks.append(data)
            if self._listen:
                self._peer = sender
        return b"".join(chunks)

    def write(self, data: bytes) -> None:
        if self._peer is None:
            return
        try:
            self._sock.sendto(data, self._peer)
        except ConnectionRefusedError:
            pass
        except OSError as exc:
            raise LinkLost(f"{self.name}: {exc.strerror}") from exc

    def close(self) -> None:
        self._sock.close()
