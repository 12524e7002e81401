"""Opening a Zenoh session as the bench's users configure it, and closing one in bounded time."""

from __future__ import annotations

import json
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import zenoh


@dataclass
class ZenohOptions:
    """Peer mode with multicast scouting by default (zero configuration on one machine); `connect` and
    `listen` endpoints (e.g. tcp/192.0.2.10:7447) join an existing Zenoh network; or a config file."""

    connect: list[str] = field(default_factory=list)
    listen: list[str] = field(default_factory=list)
    config_file: Path | None = None
    multicast_scouting: bool = True


def close_within(close: Callable[[], None], timeout_s: float = 1.0) -> None:
    """Run a Zenoh close in a daemon thread and wait at most `timeout_s`: a stalled or vanished peer can
    hold a session's close for many seconds, and nobody should wait for it."""
    closer = threading.Thread(target=close, name="zenoh-close", daemon=True)
    closer.start()
    closer.join(timeout_s)


def open_session(options: ZenohOptions) -> zenoh.Session:
    return zenoh.open(zenoh_config(options))


def zenoh_config(options: ZenohOptions) -> zenoh.Config:
    """The session's configuration; zenoh.ZError for a file or endpoint Zenoh cannot use."""
    config = zenoh.Config.from_file(str(options.config_file)) if options.config_file else zenoh.Config()
    if options.connect:
        config.insert_json5("connect/endpoints", json.dumps(options.connect))
    if options.listen:
        config.insert_json5("listen/endpoints", json.dumps(options.listen))
    if not options.multicast_scouting:
        config.insert_json5("scouting/multicast/enabled", "false")
    elif not options.config_file:
        # Zenoh's open waits 0.5 s for multicast scouting to find peers before it returns; a peer on this machine
        # answers within ~1 ms (a subscriber already running missed only the first of 1 kHz samples put right
        # after an open without the wait), and one that joins later gets the run from then on, as always
        config.insert_json5("scouting/delay", "0")
    return config
