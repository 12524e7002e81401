"""`hil foxglove`: a run seen on Zenoh (this or another machine's bench) served to Foxglove over its WebSocket
protocol, with the recording's channels and schemas."""

from __future__ import annotations

import threading
import time

import orjson
import zenoh

from hil.app.watch import RunFinder
from hil.channels import CHANNEL_MODELS
from hil.outputs.foxglove_live import FoxgloveServer
from hil.outputs.foxglove_messages import mission_scene
from hil.outputs.telemetry import KEY_PREFIX, fetch_meta
from hil.scenario.schema import READ_PLANT, Scenario


def bridge_zenoh(session: zenoh.Session, run_id: str | None, address: str, wait_s: float,
                 stop: threading.Event) -> str:
    """Serve the run `run_id` (or the first one seen) from Zenoh to a Foxglove WebSocket until its summary
    arrives or `stop` is set; returns a one-line reason."""
    chosen = run_id or _first_run(session, wait_s)
    if chosen is None:
        return f"no run seen on Zenoh within {wait_s:g} s"
    meta = fetch_meta(session, chosen)
    if meta is None:
        return f"run {chosen}: its meta did not answer (has it ended?)"
    scenario = Scenario.model_validate(meta["scenario"], context={READ_PLANT: False})  # its plant is the bench's
    home = scenario.home
    start_ns = int(meta.get("start_unix_ns") or time.time_ns())
    server = FoxgloveServer(address, home.frame, start_ns,
                            mission_scene(scenario, start_ns), decimate=False)
    ended = threading.Event()
    prefix = f"{KEY_PREFIX}/{chosen}/"

    def on_sample(sample: zenoh.Sample) -> None:
        channel = str(sample.key_expr)[len(prefix):]
        if channel == "summary":
            ended.set()
        elif channel in CHANNEL_MODELS:
            data = orjson.loads(sample.payload.to_bytes())
            server.publish(int(data.get("t_us", 0)), [(channel, data)])

    subscriber = session.declare_subscriber(prefix + "**", on_sample)
    print(f"hil foxglove: serving run {chosen} on ws://{address.rpartition(':')[0] or '127.0.0.1'}:{server.port}",
          flush=True)
    try:
        while not (ended.is_set() or stop.is_set()):
            ended.wait(0.2)
    finally:
        subscriber.undeclare()
        server.stop()
    return f"run {chosen} ended" if ended.is_set() else "stopped"


def _first_run(session: zenoh.Session, wait_s: float) -> str | None:
    finder = RunFinder(session)
    try:
        return finder.wait_latest(wait_s)
    finally:
        finder.close()
