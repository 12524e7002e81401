"""A paced run writes its recording on a background thread: the file must hold the same records, in the same
order, as a recording written on the stepping thread, and a writer failure must reach the stepping thread."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from mcap.reader import make_reader

from firmware_interface.geodesy import LocalFrame
from hil.loop.sink import Outcome
from hil.outputs.recorder import Recorder

STEPS = 3000  # 12 s at 250 Hz: several 1 MiB chunks, so chunks are closed on the writer thread


def _record(run_dir: Path, background: bool) -> list[tuple[str, int, bytes]]:
    run_dir.mkdir()
    recorder = Recorder(run_dir, {"name": "t"}, {}, LocalFrame(47.0, 8.0, 500.0))
    recorder.background = background
    for k in range(1, STEPS + 1):
        t_us = 4000 * k
        recorder.write_messages(t_us, [("sensors/imu", {"t_us": t_us, "accel_frd": [0.001 * k, -0.5, -9.81],
                                                        "gyro_frd": [0.0, 1e-3 * (k % 7), 0.0]}),
                                       ("actuators", {"t_us": t_us, "motors": [0.5, 0.5, 0.5, 0.5], "armed": True})])
        if k % 500 == 0:
            recorder.on_event(t_us, f"event {k}")
    recorder.close(Outcome(0, {"ok": True}, "summary"))
    with open(run_dir / "recording.mcap", "rb") as f:
        return [(channel.topic, message.log_time - recorder.start_ns, message.data)
                for _, channel, message in make_reader(f).iter_messages(log_time_order=False)]


def test_the_background_writer_records_what_the_stepping_thread_would(tmp_path):
    inline = _record(tmp_path / "inline", background=False)
    background = _record(tmp_path / "background", background=True)
    assert len(inline) == 2 * STEPS + STEPS // 500
    assert background == inline  # same records, same file order (log times relative to each run's start)
    times = [t for _, t, _ in background]
    assert times == sorted(times) and times[-1] == 4000 * STEPS * 1000


def test_a_writer_failure_is_raised_on_the_stepping_thread(tmp_path):
    recorder = Recorder(tmp_path, {"name": "t"}, {}, LocalFrame(47.0, 8.0, 500.0))
    recorder.background = True
    recorder.write_messages(4000, [("no/such/channel", {"t_us": 4000})])  # the writer thread fails on it
    deadline, k = time.monotonic() + 10.0, 2  # the writer thread fails when it gets there, however loaded the host
    with pytest.raises(OSError, match=r"recording\.mcap"):
        while time.monotonic() < deadline:
            recorder.write_messages(4000 * k, [("actuators", {"t_us": 4000 * k, "motors": [0.0] * 4,
                                                              "armed": False})])
            k += 1
    recorder.close(Outcome(0, {}, ""))
    assert (tmp_path / "summary.txt").read_text() == ""
