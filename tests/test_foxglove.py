"""Recordings Foxglove understands, the live Foxglove WebSocket, and recovery of a cut recording.

Checked against independent facts: every JSON sample against its channel's JSON Schema (jsonschema),
every Foxglove message decoded with protobuf from the schema the file carries, the Foxglove WebSocket
protocol (v1) spoken by a client written here, and MCAP's own indexed reader.
"""

from __future__ import annotations

import asyncio
import json
import math
import os
import signal
import struct
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path

import jsonschema
import numpy as np
import orjson
import pytest
import websockets
from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.records import Message
from mcap.stream_reader import StreamReader

from hil.outputs.foxglove_live import MAX_WALL_HZ
from hil.outputs.foxglove_messages import ENU_FROM_NED_WXYZ
from tests.support.ports import free_port

pytestmark = pytest.mark.e2e  # drives the bench's processes (hil, the emulator) end to end

ROOT = Path(__file__).resolve().parent.parent
# The Foxglove WebSocket protocol: foxglove-sdk's server speaks it under its current name, the Foxglove app
# offers both names; the messages are those of foxglove.websocket.v1.
SUBPROTOCOLS = ["foxglove.websocket.v1", "foxglove.sdk.v1"]


def hover_file(tmp_path: Path, seconds: float) -> Path:
    path = tmp_path / "fox.yaml"
    path.write_text(f"name: fox\nduration_s: {seconds}\nseed: 3\nreference: {{type: hover, altitude_m: 3}}\n"
                    "wind: {steady_ned: [2, 1, 0], turbulence: {intensity: light}}\n")
    return path


def hil(*args: str, **kwargs) -> subprocess.Popen[str]:
    return subprocess.Popen([sys.executable, "-m", "hil", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, cwd=ROOT, **kwargs)


def only_run_dir(runs: Path) -> Path:
    (run_dir,) = runs.iterdir()
    return run_dir


@pytest.fixture(scope="module")
def gust_run(shipped_flight) -> Path:
    """The shipped gust.yaml as a user flies it (the flight the shipped-scenario tests judge too)."""
    result, run_dir = shipped_flight(ROOT / "scenarios" / "gust.yaml")
    assert result.returncode == 0, result.stdout + result.stderr
    return run_dir


def protobuf_decoder(schema_name: str, file_descriptor_set: bytes):
    files = descriptor_pb2.FileDescriptorSet.FromString(file_descriptor_set)
    pool = descriptor_pool.DescriptorPool()
    for proto in files.file:
        pool.Add(proto)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(schema_name))


def test_every_recorded_message_validates_against_its_channels_schema(gust_run):
    validators, decoders, counts = {}, {}, Counter()
    with open(gust_run / "recording.mcap", "rb") as f:
        reader = make_reader(f)
        for schema, channel, message in reader.iter_messages():
            counts[channel.topic] += 1
            if channel.message_encoding == "json":
                if channel.topic not in validators:
                    definition = json.loads(schema.data)
                    assert set(definition) - {"$schema", "title", "type"}, f"{channel.topic}: a bare schema"
                    assert schema.encoding == "jsonschema"
                    validators[channel.topic] = jsonschema.Draft202012Validator(definition)
                validators[channel.topic].validate(orjson.loads(message.data))
            else:
                assert channel.message_encoding == "protobuf" and schema.name.startswith("foxglove.")
                if channel.topic not in decoders:
                    decoders[channel.topic] = protobuf_decoder(schema.name, schema.data)
                decoded = decoders[channel.topic].FromString(message.data)
                assert decoded.ByteSize() > 0
    assert counts["hil/state"] > 20_000 and counts["hil/board/estimates"] > 1000
    assert counts["foxglove/tf"] > 1000 and counts["foxglove/gps"] > 100 and counts["foxglove/scene"] == 1
    board = {t for t in counts if t.startswith("hil/board/")}
    assert {"hil/board/heartbeat", "hil/board/attitude_target", "hil/board/command_ack",
            "hil/board/local_position_ned", "hil/board/statustext"} <= board


def test_every_field_of_every_channel_says_what_it_is(gust_run):
    with open(gust_run / "recording.mcap", "rb") as f:
        summary = make_reader(f).get_summary()
    for channel in summary.channels.values():
        if channel.message_encoding != "json":
            continue
        definition = json.loads(summary.schemas[channel.schema_id].data)
        for name, field in definition["properties"].items():
            assert field.get("description"), f"{channel.topic}.{name} has no description"
    state = json.loads(next(summary.schemas[c.schema_id].data for c in summary.channels.values()
                            if c.topic == "hil/state"))
    description = state["properties"]["pos_ned"]["description"]
    assert "NED" in description and "m" in description


def test_metadata_and_log_times_on_the_wall_clock(gust_run):
    meta = json.loads((gust_run / "meta.json").read_text())
    start_ns = meta["start_unix_ns"]
    assert abs(start_ns / 1e9 - time.time()) < 3600  # today's date in a viewer, not 1970
    with open(gust_run / "recording.mcap", "rb") as f:
        reader = make_reader(f)
        metadata = {m.name: m.metadata for m in reader.iter_metadata()}
        for _, _channel, message in reader.iter_messages(topics=["hil/state"]):
            assert message.log_time == start_ns + orjson.loads(message.data)["t_us"] * 1000
    assert "gust" in metadata["scenario"]["yaml"]
    assert json.loads(metadata["run"]["json"])["scenario"] == "gust"
    recorded_metrics = json.loads(metadata["metrics"]["json"])
    assert recorded_metrics == json.loads((gust_run / "metrics.json").read_text())


def test_enu_display_frame_holds_ned_axes_where_they_point():
    """NED's north, east, down seen in the z-up ENU frame: (0,1,0), (1,0,0), (0,0,-1), by q v q*."""
    q = np.array(ENU_FROM_NED_WXYZ)
    w, v = q[0], q[1:]

    def rotate(x: np.ndarray) -> np.ndarray:
        return x + 2 * w * np.cross(v, x) + 2 * np.cross(v, np.cross(v, x))

    assert math.isclose(float(np.linalg.norm(q)), 1.0)
    np.testing.assert_allclose(rotate(np.array((1.0, 0, 0))), (0, 1, 0), atol=1e-12)
    np.testing.assert_allclose(rotate(np.array((0, 1.0, 0))), (1, 0, 0), atol=1e-12)
    np.testing.assert_allclose(rotate(np.array((0, 0, 1.0))), (0, 0, -1), atol=1e-12)


async def _foxglove_client(url: str, topic: str, wanted: int, timeout_s: float) -> tuple[dict, list[tuple[int, dict]]]:
    """Foxglove WebSocket protocol v1: read the advertisements, subscribe to `topic`, collect messages
    (binary opcode 0x01: subscription id u32, log time u64, payload)."""
    deadline = time.monotonic() + timeout_s
    while True:
        try:
            socket_ = await websockets.connect(url, subprotocols=SUBPROTOCOLS, max_size=None)
            break
        except OSError:
            if time.monotonic() > deadline:
                raise
            await asyncio.sleep(0.1)
    channels: dict[str, dict] = {}
    received: list[tuple[int, dict]] = []
    async with socket_:
        assert socket_.subprotocol in SUBPROTOCOLS
        while len(received) < wanted and time.monotonic() < deadline:
            frame = await asyncio.wait_for(socket_.recv(), deadline - time.monotonic())
            if isinstance(frame, str):
                message = json.loads(frame)
                if message["op"] == "advertise":
                    channels.update({c["topic"]: c for c in message["channels"]})
                    if topic in channels:
                        await socket_.send(json.dumps({"op": "subscribe", "subscriptions": [
                            {"id": 7, "channelId": channels[topic]["id"]}]}))
            elif frame[0] == 0x01:
                subscription, log_ns = struct.unpack_from("<IQ", frame, 1)
                assert subscription == 7
                received.append((log_ns, json.loads(frame[13:])))
    return channels, received


@pytest.mark.slow
def test_a_websocket_client_sees_the_run_live(tmp_path):
    port = free_port()
    bench = hil("run", str(hover_file(tmp_path, 20.0)), "--runs", str(tmp_path / "runs"), "--no-telemetry",
                "--no-gcs", "--realtime", "--foxglove", f"127.0.0.1:{port}")
    try:
        channels, received = asyncio.run(_foxglove_client(f"ws://127.0.0.1:{port}", "hil/state", 100, 60.0))
    finally:
        bench.send_signal(signal.SIGINT)
        bench.communicate(timeout=30)
    assert {"hil/state", "hil/reference", "hil/board/attitude_target", "foxglove/tf", "foxglove/gps"} <= set(channels)
    state = channels["hil/state"]
    assert state["encoding"] == "json" and state["schemaEncoding"] == "jsonschema"
    validator = jsonschema.Draft202012Validator(json.loads(state["schema"]))
    assert channels["foxglove/tf"]["schemaName"] == "foxglove.FrameTransforms"
    assert len(received) == 100
    stamps = [sample["t_us"] for _, sample in received]
    assert stamps == sorted(stamps) and len(set(stamps)) == len(stamps)
    # decimated like the Zenoh telemetry (50 per simulated second: on a 20 ms grid), then capped for a person
    # watching at MAX_WALL_HZ per wall second; paced in real time the two give 30 a second on average
    assert all(t % 20_000 == 0 for t in stamps[1:])  # (the run's first sample, at 4 ms, opens the grid)
    assert (stamps[-1] - stamps[0]) / (len(stamps) - 1) == pytest.approx(1e6 / MAX_WALL_HZ, rel=0.05)
    for _log_ns, sample in received:
        validator.validate(sample)
    assert abs(received[0][0] / 1e9 - time.time()) < 120  # log time on the wall clock


def _killed_mid_flight(tmp_path: Path) -> Path:
    runs = tmp_path / "runs"
    bench = hil("run", "scenarios/gust.yaml", "--runs", str(runs), "--no-telemetry", "--no-gcs",
                start_new_session=True)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        dirs = list(runs.glob("*")) if runs.exists() else []
        if dirs and (dirs[0] / "recording.mcap").is_file() and (dirs[0] / "recording.mcap").stat().st_size > 2_000_000:
            break
        time.sleep(0.1)
    os.killpg(bench.pid, signal.SIGKILL)
    bench.communicate(timeout=30)
    return only_run_dir(runs)


def _streamed_messages(path: Path) -> list[tuple[int, int, bytes]]:
    """Every whole message a streaming reader gets from the file before it hits the cut."""
    out = []
    with open(path, "rb") as f:
        try:
            for record in StreamReader(f).records:
                if isinstance(record, Message):
                    out.append((record.channel_id, record.log_time, record.data))
        except (McapError, EOFError, ValueError):
            pass
    return out


def _indexed_messages(path: Path) -> list[tuple[str, int, bytes]]:
    with open(path, "rb") as f:
        return [(c.topic, m.log_time, m.data) for _, c, m in make_reader(f).iter_messages(log_time_order=False)]


@pytest.mark.slow
def test_recover_rebuilds_a_recording_cut_by_sigkill(tmp_path):
    run_dir = _killed_mid_flight(tmp_path)
    recording = run_dir / "recording.mcap"
    assert not (run_dir / "summary.txt").exists()
    with pytest.raises((McapError, ValueError, AssertionError, struct.error)):
        _indexed_messages(recording)  # the indexed reader refuses the cut file
    streamed = _streamed_messages(recording)
    assert len(streamed) > 10_000
    result = subprocess.run([sys.executable, "-m", "hil", "recover", str(run_dir)], capture_output=True,
                            text=True, cwd=ROOT, timeout=120)
    assert result.returncode == 0, result.stderr
    recovered = _indexed_messages(recording)
    assert [(t, d) for _, t, d in streamed] == [(t, d) for _, t, d in recovered]
    assert (run_dir / "recording.mcap.cut").is_file()
    assert (run_dir / "summary.txt").read_text().startswith("recovered:")
    again = subprocess.run([sys.executable, "-m", "hil", "recover", str(run_dir)], capture_output=True,
                           text=True, cwd=ROOT, timeout=60)
    assert again.returncode == 0 and "complete already" in again.stdout


@pytest.mark.slow
def test_hil_foxglove_serves_a_run_seen_on_zenoh(tmp_path):
    zenoh_endpoint, port = f"tcp/127.0.0.1:{free_port()}", free_port()
    bench = hil("run", str(hover_file(tmp_path, 20.0)), "--runs", str(tmp_path / "runs"), "--no-gcs", "--realtime",
                "--zenoh-listen", zenoh_endpoint)
    bridge = hil("foxglove", "--zenoh-connect", zenoh_endpoint, "--listen", f"127.0.0.1:{port}", "--wait", "30")
    try:
        channels, received = asyncio.run(_foxglove_client(f"ws://127.0.0.1:{port}", "hil/state", 50, 60.0))
    finally:
        bench.send_signal(signal.SIGINT)
        bench.communicate(timeout=30)
        out, err = bridge.communicate(timeout=30)
    assert "hil/state" in channels and "foxglove/tf" in channels
    assert len(received) == 50
    stamps = [sample["t_us"] for _, sample in received]
    assert stamps == sorted(stamps)
    assert bridge.returncode == 0, out + err  # the run's summary ended the bridge
    assert "ended" in out


def _layout_paths(node: object) -> list[str]:
    if isinstance(node, dict):
        found = [node["value"]] if isinstance(node.get("value"), str) and node["value"].startswith('"') else []
        return found + [p for v in node.values() for p in _layout_paths(v)]
    if isinstance(node, list):
        return [p for v in node for p in _layout_paths(v)]
    return []


def test_the_shipped_foxglove_layout_plots_fields_the_recording_has():
    from hil.channels import CHANNEL_MODELS

    layout = json.loads((ROOT / "docs" / "foxglove_layout.json").read_text())
    paths = _layout_paths(layout)
    assert len(paths) >= 20
    for path in paths:
        topic, _, field = path[1:].partition('".')
        assert topic.startswith("hil/") and topic[4:] in CHANNEL_MODELS, path
        name = field.split("[")[0].split(".")[0]
        assert name in CHANNEL_MODELS[topic[4:]].model_fields, path
