"""A recording's content on simulated time, and its digest: what two runs of one scenario and seed share
bit for bit (the wall-clock start, the timing channel and Foxglove's wall-clock-stamped views aside).

`tests/support/recording_checksums.json` keeps the digest of every shipped scenario as flown before a refactor, so
that a change meant to keep behaviour is shown to keep it. Floating point is only reproducible on the
same numeric platform (CPU features that pick numpy's and libm's code paths, their versions, numba's, and the
kernels OpenBLAS picked for the CPU model, which `OPENBLAS_CORETYPE` can override), so the file
keeps one set of digests per platform, each made from a revision whose flights were shown bit for bit
equal to the earlier set's. After a deliberate change of flight results, regenerate them with
`python -m tests.support.recording_digest` on each platform and say in CHANGELOG.md what changed and why.
"""

from __future__ import annotations

import hashlib
import json
import platform
import struct
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import lz4.frame
import numba
import numpy as np
import zstandard
from mcap.reader import make_reader
from threadpoolctl import threadpool_info

ROOT = Path(__file__).resolve().parents[2]
CHECKSUMS = Path(__file__).with_name("recording_checksums.json")
NOT_REPRODUCIBLE = {"link_faults": "paced in real time: which frame a wall-clock latency or loss hits "
                    "depends on the machine's timing, so two runs of it differ"}
SIMD_FLAGS = ("fma", "avx2", "avx512f", "avx512dq", "avx512bw", "avx512vl")  # what numpy and glibc dispatch on


def simulated_content(run_dir: Path) -> list[tuple[str, int, bytes]]:
    """(topic, log time less the run's wall-clock start in ns, payload) of the bench's own channels, in log-time
    order (messages of one time in the order written, as the indexed `mcap` reader gives them; the file is
    read record by record here, several times faster: tests/test_hil_run.py checks both give the same)."""
    start_ns = json.loads((run_dir / "meta.json").read_text())["start_unix_ns"]
    messages = [(topic, log_time - start_ns, data) for topic, log_time, data in _messages_in_file_order(
        (run_dir / "recording.mcap").read_bytes()) if topic.startswith("hil/") and topic != "hil/timing"]
    return sorted(messages, key=lambda m: m[1])  # stable: ties keep the file's order


def simulated_content_by_the_mcap_reader(run_dir: Path) -> list[tuple[str, int, bytes]]:
    """`simulated_content` as the `mcap` package's indexed reader reads it (the reference for the fast read)."""
    start_ns = json.loads((run_dir / "meta.json").read_text())["start_unix_ns"]
    with open(run_dir / "recording.mcap", "rb") as f:
        return [(channel.topic, message.log_time - start_ns, message.data)
                for _, channel, message in make_reader(f).iter_messages(log_time_order=True)
                if channel.topic.startswith("hil/") and channel.topic != "hil/timing"]


_MAGIC, _CHANNEL, _MESSAGE, _CHUNK, _DATA_END = b"\x89MCAP0\r\n", 0x04, 0x05, 0x06, 0x0F
_DECOMPRESS = {"": lambda data, _size: data, "lz4": lambda data, _size: lz4.frame.decompress(data),
               "zstd": lambda data, size: zstandard.ZstdDecompressor().decompress(data, max_output_size=size)}


def _messages_in_file_order(data: bytes) -> list[tuple[str, int, bytes]]:
    """(topic, log time ns, payload) of every message of an MCAP file (the MCAP specification's records: opcode,
    length, body; messages and channels inside chunks or beside them), in the order they were written."""
    assert data[:8] == _MAGIC, "not an MCAP file"
    topics: dict[int, str] = {}
    out: list[tuple[str, int, bytes]] = []
    _records(data, 8, len(data), topics, out)
    return out


def _records(data: bytes, at: int, end: int, topics: dict[int, str], out: list[tuple[str, int, bytes]]) -> None:
    while at < end:
        opcode, length = data[at], int.from_bytes(data[at + 1:at + 9], "little")
        body = at + 9
        if opcode == _MESSAGE:
            channel_id, log_time = struct.unpack_from("<H4xQ", data, body)
            out.append((topics[channel_id], log_time, data[body + 22:body + length]))
        elif opcode == _CHANNEL:
            channel_id = int.from_bytes(data[body:body + 2], "little")
            size = int.from_bytes(data[body + 4:body + 8], "little")
            topics[channel_id] = data[body + 8:body + 8 + size].decode()
        elif opcode == _CHUNK:
            uncompressed = int.from_bytes(data[body + 16:body + 24], "little")
            size = int.from_bytes(data[body + 28:body + 32], "little")
            compression = data[body + 32:body + 32 + size].decode()
            records_at = body + 32 + size + 8
            records = _DECOMPRESS[compression](data[records_at:body + length], uncompressed)
            _records(records, 0, len(records), topics, out)
        elif opcode == _DATA_END:
            return
        at = body + length


def simulated_digest(run_dir: Path) -> str:
    """SHA-256 over `simulated_content`, each field length-prefixed so that no two contents collide."""
    digest = hashlib.sha256()
    for topic, t_ns, data in simulated_content(run_dir):
        for part in (topic.encode(), str(t_ns).encode(), data):
            digest.update(len(part).to_bytes(8, "little"))
            digest.update(part)
    return digest.hexdigest()


def numeric_platform() -> dict[str, Any]:
    """What decides the last bit of a floating-point result here: the CPU's vector features, libm, numpy, numba
    (it compiles the flight code), and the kernel set numpy's BLAS picked for this CPU model (two machines with
    the same flags can differ in it)."""
    try:
        flags = set(Path("/proc/cpuinfo").read_text().split("flags")[1].split("\n")[0].split())
    except (OSError, IndexError):
        flags = set()
    blas = [f"{pool['internal_api']} {pool.get('version')} {pool.get('architecture')}" for pool in threadpool_info()
            if pool["user_api"] == "blas"]
    return {"machine": platform.machine(), "libc": "-".join(platform.libc_ver()), "numpy": np.__version__,
            "numba": numba.__version__, "simd": [f for f in SIMD_FLAGS if f in flags], "blas": blas}


def recorded_here() -> dict[str, Any] | None:
    """The digests made on this numeric platform, if any."""
    entries = json.loads(CHECKSUMS.read_text())["platforms"]
    return next((entry for entry in entries if entry["platform"] == numeric_platform()), None)


def shipped_scenarios() -> list[Path]:
    """The shipped scenarios (the emulator flies them all)."""
    return sorted((ROOT / "scenarios").glob("*.yaml"))


def main() -> int:
    """Fly every shipped scenario on the emulator and write their digests to CHECKSUMS."""
    digests = {}
    with tempfile.TemporaryDirectory() as tmp:
        for scenario in shipped_scenarios():
            if scenario.stem in NOT_REPRODUCIBLE:
                continue
            runs = Path(tmp) / scenario.stem
            subprocess.run([sys.executable, "-m", "hil", "run", str(scenario), "--runs", str(runs),
                            "--no-report", "--no-telemetry", "--no-gcs"], cwd=ROOT, check=True,
                           stdout=subprocess.DEVNULL)
            (run_dir,) = runs.iterdir()
            digests[scenario.stem] = simulated_digest(run_dir)
            print(f"{scenario.stem}: {digests[scenario.stem]}")
    revision = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True,
                              text=True).stdout.strip()
    here = {"platform": numeric_platform(), "recorded_at_revision": revision, "scenarios": digests}
    known = json.loads(CHECKSUMS.read_text())["platforms"] if CHECKSUMS.exists() else []
    platforms = [entry for entry in known if entry["platform"] != here["platform"]] + [here]
    CHECKSUMS.write_text(json.dumps({"not_reproducible": NOT_REPRODUCIBLE, "platforms": platforms}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
