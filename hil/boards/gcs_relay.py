"""Ground-station forwarding: the bench holds the board's port, so it relays, as a MAVLink router does,
the board's traffic (all but the HIL sensor/actuator frames) to each GCS endpoint and what a GCS sends
back to the board. QGroundControl listens on UDP 14550 by default: `udpout:127.0.0.1:14550`.

Frames are relayed whole, as received (system ids kept); GCS frames reach the board after the bench's
own frames of a step, in a write of their own, so they never split or reorder the HIL exchange.
"""

from __future__ import annotations

from firmware_interface.link import Link, LinkError, open_link

DEFAULT_GCS = "udpout:127.0.0.1:14550"  # QGroundControl listens here (PX4 SITL's GCS instance sends here)
DEFAULT_API = "udpout:127.0.0.1:14540"  # MAVSDK and MAVROS listen here (PX4 SITL's offboard/API instance sends here)


def default_endpoints(kind_default: tuple[str, ...], bench_flies: bool) -> list[str]:
    """Where the relay sends when the user names no endpoint: the board kind's default (QGroundControl's port, or
    none for PX4 SITL, which serves it itself), and MAVSDK's and MAVROS's port too when the bench does not fly, as
    PX4 SITL serves an outside pilot; with the bench flying an API client would fight its offboard stream."""
    return [*kind_default, *((DEFAULT_API,) if kind_default and not bench_flies else ())]


class GcsBridge:
    def __init__(self, endpoints: list[str]) -> None:
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

    def to_gcs(self, frames: list[bytes]) -> None:
        """Send the board's frames to every GCS; a GCS that is not there costs nothing (UDP)."""
        for link in self.links:
            for frame in frames:
                link.transport.write(frame)
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
