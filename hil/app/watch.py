"""`hil watch` (a live terminal view of a run) and `hil echo` (JSON lines), both Zenoh subscribers."""

from __future__ import annotations

import math
import sys
import threading
import time
from collections.abc import Callable
from typing import Any

import orjson
import zenoh
from rich.console import Group, RenderableType
from rich.live import Live
from rich.table import Table

from firmware_interface.emulator.geometry import quat_to_euler
from hil.outputs.telemetry import KEY_PREFIX
from hil.outputs.zenoh_session import ZenohOptions, close_within, open_session

REFRESH_HZ = 4.0


class RunFinder:
    """Follows the liveliness tokens `hil/<run_id>` of running benches (history: also those already up)."""

    def __init__(self, session: zenoh.Session) -> None:
        self.alive: dict[str, float] = {}
        self.ended: set[str] = set()
        self.changed = threading.Event()
        self._subscriber = session.liveliness().declare_subscriber(f"{KEY_PREFIX}/*", self._on_token, history=True)

    def _on_token(self, sample: zenoh.Sample) -> None:
        run_id = str(sample.key_expr).split("/", 1)[1]
        if sample.kind == zenoh.SampleKind.PUT:
            self.alive[run_id] = time.monotonic()
        else:
            self.alive.pop(run_id, None)
            self.ended.add(run_id)
        self.changed.set()

    def latest(self) -> str | None:
        return max(self.alive) if self.alive else None  # run ids start with their UTC start time

    def wait_latest(self, wait_s: float) -> str | None:
        """The newest running bench, waiting up to `wait_s` for one to appear."""
        return self._wait(self.latest, wait_s)

    def wait_for(self, run_id: str, wait_s: float) -> str | None:
        """`run_id` once it runs (its token is up), waiting up to `wait_s`; None for a run that is unknown
        or has ended."""
        return self._wait(lambda: run_id if run_id in self.alive else None, wait_s)

    def _wait(self, found: Callable[[], str | None], wait_s: float) -> str | None:
        deadline = time.monotonic() + wait_s
        while (run_id := found()) is None and time.monotonic() < deadline:
            self.changed.wait(0.2)
            self.changed.clear()
        return run_id

    def close(self) -> None:
        self._subscriber.undeclare()


class RunView:
    """The latest sample per channel of one run, and the table drawn from them."""

    def __init__(self, run_id: str) -> None:
        self.run_id = run_id
        self.latest: dict[str, dict[str, Any]] = {}
        self.events: list[str] = []
        self.summary: str | None = None
        self.started_wall = time.monotonic()
        self.first_t_us: int | None = None
        self.lock = threading.Lock()

    def on_sample(self, sample: zenoh.Sample) -> None:
        channel = str(sample.key_expr).split("/", 2)[2]
        try:
            data = orjson.loads(sample.payload.to_bytes())
        except orjson.JSONDecodeError:
            return
        with self.lock:
            if channel == "events":
                self.events = [*self.events, f"{data['t_us'] / 1e6:8.2f} s  {data['text']}"][-6:]
            elif channel == "summary":
                self.summary = data["text"]
            else:
                self.latest[channel] = data
            if self.first_t_us is None and "t_us" in data:
                self.first_t_us, self.started_wall = data["t_us"], time.monotonic()

    def render(self) -> Group:
        with self.lock:
            latest = dict(self.latest)
            events = list(self.events)
        state, ref = latest.get("state", {}), latest.get("reference", {})
        table = Table(title=f"hil run {self.run_id}", show_header=True, expand=False)
        for column in ("", "x / N", "y / E", "z / D"):
            table.add_column(column, justify="right")

        def row(label: str, values: Any, fmt: str = "{:+8.3f}") -> None:
            table.add_row(label, *(fmt.format(v) for v in values) if values else ("–",) * 3)

        pos, ref_pos = state.get("pos_ned"), ref.get("pos_ned")
        row("position (m)", pos)
        row("reference (m)", ref_pos)
        row("error (m)", [p - r for p, r in zip(pos, ref_pos, strict=True)] if pos and ref_pos else None)
        row("velocity (m/s)", state.get("vel_ned"))
        row("roll/pitch/yaw (deg)", [math.degrees(a) for a in state["rpy"]] if "rpy" in state else None, "{:+8.2f}")
        target = latest.get("board/attitude_target")
        if target:
            cmd = quat_to_euler(target["q"])
            row("commanded (deg)", [math.degrees(a) for a in cmd], "{:+8.2f}")
        env = latest.get("environment", {})
        row("wind (m/s)", env.get("wind_ned"))
        motors = latest.get("actuators", {}).get("motors")
        lines: list[RenderableType] = [table]
        info = Table.grid(padding=(0, 2))
        sim_s = state.get("t_us", 0) / 1e6
        wall = time.monotonic() - self.started_wall
        rtf = (state.get("t_us", 0) - (self.first_t_us or 0)) / 1e6 / wall if wall > 0.5 else float("nan")
        info.add_row("phase", str(state.get("phase", "–")), "sim time", f"{sim_s:.1f} s",
                     "real-time factor", f"{rtf:.1f}x")
        info.add_row("motors", " ".join(f"{m:.2f}" for m in motors) if motors else "–",
                     "payload", f"{env.get('payload_kg', 0.0):.2f} kg",
                     "armed", str(latest.get("actuators", {}).get("armed")))
        link = latest.get("board/link")
        if link:
            errors = {k: v for k, v in link.items() if k not in ("t_us", "frames_in", "frames_out",
                                                                  "bytes_in", "bytes_out") and v}
            info.add_row("link", f"{link.get('frames_in', 0)} in / {link.get('frames_out', 0)} out", "errors",
                         str(errors or "none"), "", "")
        debug = latest.get("board/estimates")
        if debug:
            values = debug.get("values", {})
            info.add_row("board estimates", "  ".join(f"{k} {v:+.3f}" for k, v in list(values.items())[:5]),
                         "", "", "", "")
        lines.append(info)
        lines.extend(events)
        return Group(*lines)


def watch(run_id: str | None, options: ZenohOptions, wait_s: float = 60.0) -> int:
    """Show a run live; returns when it ends, on Ctrl-C, or when no run appears within `wait_s`."""
    session = open_session(options)
    finder = RunFinder(session)
    subscriber = None
    try:
        wanted = run_id
        run_id = finder.wait_for(wanted, wait_s) if wanted else finder.wait_latest(wait_s)
        if run_id is None:
            what = f"run {wanted} is not running (unknown, or it has ended)" if wanted else "no running bench seen"
            print(f"hil watch: {what} within {wait_s:g} s", file=sys.stderr)
            return 1
        view = RunView(run_id)
        subscriber = session.declare_subscriber(f"{KEY_PREFIX}/{run_id}/**", view.on_sample)
        with Live(view.render(), refresh_per_second=REFRESH_HZ, transient=False) as live:
            while view.summary is None and run_id not in finder.ended:
                time.sleep(1 / REFRESH_HZ)
                live.update(view.render())
            live.update(view.render())
        if view.summary:
            print(view.summary, end="")
        return 0
    except KeyboardInterrupt:
        return 130
    finally:
        if subscriber is not None:
            subscriber.undeclare()
        finder.close()
        close_within(session.close)


def key_expr_problem(key_expr: str) -> str | None:
    """Why Zenoh would refuse `key_expr` (empty chunks, `**/**`, a `*` inside a chunk, `#` or `?`), or None."""
    try:
        zenoh.KeyExpr(key_expr)
    except zenoh.ZError as exc:
        return str(exc).split(" at /")[0].split("`: ", 1)[-1]
    return None


def echo(key_expr: str, options: ZenohOptions) -> int:
    """Every sample on `key_expr` as one JSON line `{"key": ..., "sample": ...}` on stdout."""
    session = open_session(options)
    out = sys.stdout.buffer
    lock = threading.Lock()

    def on_sample(sample: zenoh.Sample) -> None:
        line = b'{"key":"' + str(sample.key_expr).encode() + b'","sample":' + sample.payload.to_bytes() + b"}\n"
        with lock:
            try:
                out.write(line)
                out.flush()
            except (BrokenPipeError, ValueError):
                pass

    subscriber = session.declare_subscriber(key_expr, on_sample)
    try:
        while True:
            time.sleep(0.2)
    except KeyboardInterrupt:
        return 0
    finally:
        def close() -> None:
            subscriber.undeclare()
            session.close()

        close_within(close)
