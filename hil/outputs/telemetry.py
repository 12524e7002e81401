"""Live telemetry over Zenoh: key space `hil/<run_id>/<channel>`, JSON samples with `t_us`.

Publishing never blocks the loop: publishers use congestion control DROP, serialisation happens in
the bench's sink slot (which overlaps the board's computation), and a slow or dead subscriber only
loses samples. A step's samples are made only for the channels a subscriber matches now (Zenoh's matching
listeners say when that changes): with nobody listening, the usual case for a test, a sweep's sample or a flight
nobody watches, they cost ~6 µs of a ~130 µs lockstep step, for samples Zenoh then dropped. A liveliness token
`hil/<run_id>` announces a running bench and a queryable `hil/<run_id>/meta` answers the resolved scenario and
run metadata to late joiners. Rates are per channel, in samples per second of simulated time (equal to wall time
when paced in real time).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import Any

import orjson
import zenoh

from hil.channels import CHANNEL_MODELS
from hil.loop.frame import StepFrame
from hil.loop.sink import Outcome
from hil.outputs.context import OutputContext, OutputError
from hil.outputs.recorder import frame_messages
from hil.outputs.zenoh_session import ZenohOptions, close_within, open_session

DEFAULT_RATES_HZ: dict[str, float] = {
    "state": 50.0, "reference": 50.0, "sensors/imu": 50.0, "sensors/gps": 10.0, "sensors/baro": 10.0,
    "sensors/mag": 10.0, "actuators": 50.0, "environment": 10.0, "timing": 10.0,
}
LINK_PERIOD_US = 1_000_000
KEY_PREFIX = "hil"
FLUSH_S = 0.2
ZENOH_CLOSE_S = 1.0  # the longest a stalled subscriber may hold up the end of a run


class Decimator:
    """Which samples a live view passes on: each continuous channel at its rate (samples per second of
    simulated time); board messages and events, which are sparse and each matter, all of them.

    `max_wall_hz` caps a continuous channel in wall-clock time as well, for a view a person watches: in
    lockstep at 7× real time, 50 samples per simulated second are 350 a second on the screen, which no panel
    needs but which cost the machine the bench runs on."""

    def __init__(self, rates_hz: dict[str, float] | None = None, max_wall_hz: float | None = None) -> None:
        rates = {**DEFAULT_RATES_HZ, **(rates_hz or {})}
        self._period_us = {c: int(1e6 / r) for c, r in rates.items()}
        self._next_us = dict.fromkeys(rates, 0)
        self._next_link_us = 0
        self._wall_period_s = 1.0 / max_wall_hz if max_wall_hz else 0.0
        self._next_wall_s = dict.fromkeys(rates, 0.0)

    def passes(self, channel: str, t_us: int) -> bool:
        period = self._period_us.get(channel)
        if period is None:
            return True
        if t_us < self._next_us[channel]:
            return False
        self._next_us[channel] = max(self._next_us[channel] + period, t_us)
        if self._wall_period_s:
            now_s = time.monotonic()
            if now_s < self._next_wall_s[channel]:
                return False
            self._next_wall_s[channel] = max(self._next_wall_s[channel] + self._wall_period_s, now_s)
        return True

    def link_due(self, t_us: int) -> bool:
        """Once per simulated second: time to send the link counters."""
        if t_us < self._next_link_us:
            return False
        self._next_link_us = t_us + LINK_PERIOD_US
        return True


class TelemetryPublisher:
    """A bench sink that publishes every channel at its rate, plus meta, liveliness and the summary."""

    def __init__(self, session: zenoh.Session, run_id: str, meta: dict[str, Any],
                 rates_hz: dict[str, float] | None = None,
                 link_counters: Callable[[], dict[str, int]] | None = None) -> None:
        self.session = session
        self.run_id = run_id
        self.prefix = f"{KEY_PREFIX}/{run_id}"
        self._decimator = Decimator(rates_hz)
        json_encoding = zenoh.Encoding.APPLICATION_JSON
        self._publishers = {
            c: session.declare_publisher(f"{self.prefix}/{c}", encoding=json_encoding,
                                         congestion_control=zenoh.CongestionControl.DROP)
            for c in CHANNEL_MODELS
        }
        # the summary is sent once, after the loop: it may wait for the network rather than be dropped
        self._publishers["summary"] = session.declare_publisher(f"{self.prefix}/summary", encoding=json_encoding,
                                                                congestion_control=zenoh.CongestionControl.BLOCK)
        self.heard_channels: set[str] = set()  # the channels a subscriber matches now, kept by Zenoh's listeners
        # called on Zenoh's own thread (`indirect=False`): the default gives each of the ~20 a Python thread
        self._listeners = [publisher.declare_matching_listener(
            zenoh.handlers.Callback(partial(self._on_matching, channel), indirect=False))
            for channel, publisher in self._publishers.items()]
        meta_payload = orjson.dumps(meta, default=str)
        self._queryable = session.declare_queryable(
            f"{self.prefix}/meta",
            lambda query: query.reply(f"{self.prefix}/meta", meta_payload, encoding=json_encoding))
        self._token = session.liveliness().declare_token(self.prefix)
        self._link_counters = link_counters
        self.published = 0

    def on_step(self, frame: StepFrame) -> None:
        heard = self.heard_channels
        if not heard:
            return
        t_us, passes = frame.t_us, self._decimator.passes
        for channel, payload in frame_messages(frame):
            if channel in heard and passes(channel, t_us):
                self._put(channel, payload)
        if self._link_counters is not None and "board/link" in heard and self._decimator.link_due(t_us):
            self._put("board/link", {"t_us": t_us, **self._link_counters()})

    def _on_matching(self, channel: str, status: zenoh.MatchingStatus) -> None:
        """Zenoh's matching listener of `channel`'s publisher (on a Zenoh thread)."""
        if status.matching:
            self.heard_channels.add(channel)
        else:
            self.heard_channels.discard(channel)

    def on_event(self, t_us: int, text: str) -> None:
        self._put("events", {"t_us": t_us, "text": text})

    def _put(self, channel: str, payload: dict[str, Any]) -> None:
        self._publishers[channel].put(orjson.dumps(payload, option=orjson.OPT_SERIALIZE_NUMPY))
        self.published += 1

    def heard(self) -> bool:
        """Whether a subscriber matches any channel now: with none, nothing is left to flush to anyone (and a run
        nobody watches, every test's and sweep sample's, ends FLUSH_S sooner)."""
        return bool(self.heard_channels)

    def close(self, outcome: Outcome) -> None:
        """The summary to subscribers, then undeclare everything and close the session (zenoh-python can hang
        on exit otherwise), in bounded time: a stopped or stalled subscriber can hold a put or the session's close
        for many seconds, and the bench does not wait for it."""
        def finish() -> None:
            self._put("summary", {"t_us": outcome.t_us, "metrics": outcome.metrics, "text": outcome.summary})
            if self.heard():  # the last samples (summary, final events) leave before the token goes
                time.sleep(FLUSH_S)
            self._token.undeclare()
            self._queryable.undeclare()
            for listener in self._listeners:
                listener.undeclare()
            for publisher in self._publishers.values():
                publisher.undeclare()
            self.session.close()

        close_within(finish, ZENOH_CLOSE_S)


def open_output(context: OutputContext) -> TelemetryPublisher | None:
    """Zenoh telemetry unless the run was asked for none; a Zenoh configuration that does not open is bad input
    (before any board starts)."""
    if context.telemetry is None:
        return None
    try:
        session = open_session(context.telemetry)
    except zenoh.ZError as exc:
        raise OutputError(f"Zenoh: {str(exc).split(' at /')[0]}") from exc
    run_id = context.run_dir.name
    return TelemetryPublisher(session, run_id, {"run_id": run_id, **context.meta,
                                                "scenario": context.resolved_scenario},
                              context.rates_hz, context.link_counters)


@dataclass
class Subscription:
    """Handle of `subscribe`: call `close()` when done (it undeclares, then closes its own session)."""

    session: zenoh.Session
    subscribers: list[Any]
    owns_session: bool

    def close(self) -> None:
        for subscriber in self.subscribers:
            subscriber.undeclare()
        if self.owns_session:
            self.session.close()


def subscribe(key_expr: str, callback: Callable[[str, dict[str, Any]], None],
              options: ZenohOptions | None = None, session: zenoh.Session | None = None) -> Subscription:
    """Call `callback(key, sample)` for every JSON sample on `key_expr` (e.g. "hil/**/state")."""
    own = session is None
    session = session or open_session(options or ZenohOptions())

    def on_sample(sample: zenoh.Sample) -> None:
        try:
            data = orjson.loads(sample.payload.to_bytes())
        except orjson.JSONDecodeError:
            return
        callback(str(sample.key_expr), data)

    return Subscription(session, [session.declare_subscriber(key_expr, on_sample)], own)


def fetch_meta(session: zenoh.Session, run_id: str, timeout_s: float = 2.0) -> dict[str, Any] | None:
    """The resolved scenario and metadata of a running bench (the `hil/<run_id>/meta` queryable)."""
    for reply in session.get(f"{KEY_PREFIX}/{run_id}/meta", timeout=timeout_s):
        if reply.ok is not None:
            return orjson.loads(reply.ok.payload.to_bytes())
    return None
