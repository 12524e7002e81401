"""Real-time factor of the same run with no subscriber, with a subscriber (another process) that takes every
sample at once, and with one that sleeps 50 ms in its callback for every sample. With no subscriber the bench makes
no samples (Zenoh's matching listeners); with one it pays for making them; a slow one must cost no more than a
prompt one (congestion: drop)."""

from __future__ import annotations

import json
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from run_timing import ROOT, benchmark_parser, scenario_file

from hil.host.lifetime import die_with_parent

# The subscriber is stopped with SIGINT (as its `except KeyboardInterrupt` expects): its handler is set here, as
# a benchmark started in a script's background (SIGINT ignored, and inherited) would otherwise never stop it.
SUBSCRIBER = """
import signal, sys, time
signal.signal(signal.SIGINT, signal.default_int_handler)
sys.path.insert(0, {root!r})
from hil.outputs.telemetry import subscribe
from hil.outputs.zenoh_session import ZenohOptions
received = []
stopping = False
def take(key, sample):
    if not stopping:  # once told to stop, the samples still queued are dropped, not slept over
        received.append(key)
        time.sleep({sleep_s})
sub = subscribe("hil/**", take, ZenohOptions(listen=[{endpoint!r}], multicast_scouting=False))
try:
    time.sleep(600)
except KeyboardInterrupt:
    stopping = True
print(len(received))
sub.close()
"""


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def run(scenario: Path, endpoint: str | None) -> float:
    with tempfile.TemporaryDirectory() as runs:
        args = [sys.executable, "-m", "hil", "run", "--no-report", str(scenario), "--runs", runs]
        args += ["--zenoh-connect", endpoint] if endpoint else ["--zenoh-listen", f"tcp/127.0.0.1:{free_port()}"]
        subprocess.run(args, check=True, capture_output=True, cwd=ROOT, preexec_fn=die_with_parent)
        metrics = json.loads((next(Path(runs).iterdir()) / "metrics.json").read_text())
        return metrics["timing"]["realtime_factor"]


def run_watched(scenario: Path, sleep_s: float) -> tuple[float, str]:
    """The run's real-time factor with a subscriber that sleeps `sleep_s` per sample, and how many it took."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    subscriber = subprocess.Popen([sys.executable, "-c", SUBSCRIBER.format(root=str(ROOT), endpoint=endpoint,
                                                                           sleep_s=sleep_s)],
                                  stdout=subprocess.PIPE, text=True,
                                  preexec_fn=die_with_parent)  # noqa: PLW1509 - dies with the benchmark
    try:
        time.sleep(2.0)
        factor = run(scenario, endpoint)
        subscriber.send_signal(signal.SIGINT)
        return factor, subscriber.communicate(timeout=30)[0].strip()
    finally:
        subscriber.kill()  # nothing if it has ended; a failed run or a hung subscriber leaves no process
        subscriber.wait()


def main() -> None:
    args = benchmark_parser(__doc__).parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        scenario = scenario_file("hover", args.quick, Path(tmp))
        alone = run(scenario, None)
        prompt, prompt_took = run_watched(scenario, 0.0)
        slow, slow_took = run_watched(scenario, 0.05)
    print("telemetry load, scenarios/hover.yaml on the emulator (lockstep)")
    print(f"  no subscriber                         : {alone:5.2f}x real time")
    print(f"  a subscriber taking every sample      : {prompt:5.2f}x real time "
          f"(it took {prompt_took} samples; ratio to none {prompt / alone:.2f}: the samples made, and a process "
          "taking them all beside the run)")
    print(f"  a subscriber sleeping 50 ms per sample: {slow:5.2f}x real time "
          f"(it took {slow_took} samples; ratio to the prompt one {slow / prompt:.2f}: what a slow one adds)")


if __name__ == "__main__":
    main()
