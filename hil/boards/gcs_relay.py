"""Ground-station forwarding: the bench holds the board's port, so it relays, as a MAVLink router does,
the board's traffic (all but the HIL sensor/actuator frames) to each GCS endpoint and what a GCS sends
back to the board. QGroundControl listens on UDP 14550 by default: `udpout:127.0.0.1:14550`.

Frames are relayed whole, as received (system ids kept); GCS frames reach the board after the bench's
own frames of a step, in a write of their own, so they never split or reorder the HIL exchange.

A relay pass runs at most every `RELAY_PERIOD_S` of wall time, not every step: a lockstep run steps every ~0.2 ms,
and a send and a look per step on each endpoint cost a gust step ~15 us (a tenth of the bench's own part). A ground
station sees the board's frames at most that much later; a paced run's steps are longer than it, so there every
step relays as before. The frames of a pass go in as few datagrams as fit an Ethernet MTU (MAVLink over UDP allows
several frames in one; QGroundControl, MAVSDK and pymavlink read them all).
"""

from __future__ import annotations

import time
from collections.abc import Callable

from firmware_interface.link import Link, LinkError, open_link

DEFAULT_GCS = "udpout:127.0.0.1:14550"  # QGroundControl listens here (PX4 SITL's GCS instance sends here)
DEFAULT_API = "udpout:127.0.0.1:14540"  # MAVSDK and MAVROS listen here (PX4 SITL's offboard/API instance sends here)
RELAY_PERIOD_S = 1e-3  # a ground station's latency budget is tens of ms; a lockstep step is ~0.2 ms
DATAGRAM_BYTES = 1472  # an Ethernet MTU less the IP and UDP headers: no datagram of the relay is fragmented


def default_endpoints(kind_default: tuple[str, ...], bench_flies: bool) -> list[str]:
    """Where the relay sends when the user names no endpoint: the board kind's default (QGroundControl's port, or
    none for PX4 SITL, which serves it itself), and MAVSDK's and MAVROS's port too when the bench does not fly, as
    PX4 SITL serves an outside pilot; with the bench flying an API client would fight its offboard stream."""
    return [*kind_default, *((DEFAULT_API,) if kind_default and not bench_flies else ())]


def datagrams(frames: list[bytes]) -> list[bytes]:
    """The frames in order, whole, joined into as few datagrams of at most `DATAGRAM_BYTES` as they fit (a larger
    frame alone: MAVLink 2's largest is 280 bytes, so only for a peer's odd traffic)."""
    out: list[bytes] = []
    held: list[bytes] = []
    size = 0
    for frame in frames:
        if held and size + len(frame) > DATAGRAM_BYTES:
            out.append(b"".join(held))
            held, size = [], 0
        held.append(frame)
        size += len(frame)
    if held:
        out.append(b"".join(held))
    return out


class GcsBridge:
    def __init__(self, endpoints: list[str], clock: Callable[[], float] = time.monotonic) -> None:
        self.clock = clock
        self._next_pass_s = 0.0
        self.links: list[Link] = []
        try:
            for endpoint in endpoints:
                self.links.append(open_link(endpoint))
        except LinkError:
            self.close()
            raise
        self.frames_to_gcs = 0
        self.frames_from_gcs = 0

    @property
    def endpoints(self) -> list[str]:
        return [link.name for link in self.links]

    def due(self) -> bool:
        """Whether a relay pass is due now (`RELAY_PERIOD_S` after the last one began); True starts one."""
        now = self.clock()
        if now < self._next_pass_s:
            return False
        self._next_pass_s = now + RELAY_PERIOD_S
        return True

    def to_gcs(self, frames: list[bytes]) -> None:
        """Send the board's frames to every GCS; a GCS that is not there costs nothing (UDP)."""
        packed = datagrams(frames)
        for link in self.links:
            for datagram in packed:
                link.transport.write(datagram)
        self.frames_to_gcs += len(frames)

    def from_gcs(self) -> list[bytes]:
        """Whole frames every GCS has sent since the last call (never waits)."""
        frames = [bytes(msg.get_msgbuf()) for link in self.links for msg in link.receive(0.0)]
        self.frames_from_gcs += len(frames)
        return frames

    def counters(self) -> dict[str, object]:
        return {"endpoints": self.endpoints, "frames_to_gcs": self.frames_to_gcs,
                "frames_from_gcs": self.frames_from_gcs}

    def close(self) -> None:
        for link in self.links:
            link.close()
