"""`hil recover RUN_DIR`: a recording cut short (power loss, `kill -9`) becomes a complete, indexed MCAP.

The recorder flushes each finished chunk to disk, so a cut file holds every chunk but the one being
filled, and lacks the summary section and footer that indexed readers need. Recovery streams the
records up to the first incomplete one (CRCs checked) and writes them into a new, properly finished
file; the cut original is kept beside it as `recording.mcap.cut`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.records import Channel, Message, Metadata, Schema
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer

from hil.outputs.recorder import CHUNK_BYTES

RECORDING = "recording.mcap"
CUT_SUFFIX = ".cut"


class RecoverError(RuntimeError):
    """Nothing to recover from (no recording, or not an MCAP file)."""


@dataclass
class Recovered:
    messages: int
    last_log_time_ns: int | None
    already_complete: bool


def is_complete(path: Path) -> bool:
    """An indexed reader can open the file (it has its summary section and footer)."""
    try:
        with open(path, "rb") as f:
            return make_reader(f).get_summary() is not None
    except (McapError, OSError, ValueError, AssertionError):
        return False


def recover(run_dir: Path) -> Recovered:
    path = run_dir / RECORDING
    if not path.is_file():
        raise RecoverError(f"{run_dir}: no {RECORDING} to recover")
    if is_complete(path):
        return Recovered(0, None, already_complete=True)
    cut = path.with_name(RECORDING + CUT_SUFFIX)
    path.replace(cut)
    with open(cut, "rb") as source, open(path, "wb") as target:
        count, last = _copy_whole_records(source, target)
    _mark_summary(run_dir, count, last)
    return Recovered(count, last, already_complete=False)


def _copy_whole_records(source: object, target: object) -> tuple[int, int | None]:
    writer = Writer(target, chunk_size=CHUNK_BYTES, compression=CompressionType.ZSTD)  # type: ignore[arg-type]
    writer.start(profile="", library="hil-bench recover")
    schemas: dict[int, int] = {}
    channels: dict[int, int] = {}
    count, last = 0, None
    try:
        for record in StreamReader(source, validate_crcs=True).records:  # type: ignore[arg-type]
            if isinstance(record, Schema):
                schemas[record.id] = writer.register_schema(record.name, record.encoding, record.data)
            elif isinstance(record, Channel):
                channels[record.id] = writer.register_channel(record.topic, record.message_encoding,
                                                              schemas.get(record.schema_id, 0), record.metadata)
            elif isinstance(record, Message) and record.channel_id in channels:
                writer.add_message(channels[record.channel_id], record.log_time, record.data, record.publish_time,
                                   record.sequence)
                count, last = count + 1, record.log_time
            elif isinstance(record, Metadata):
                writer.add_metadata(record.name, record.metadata)
    except (McapError, EOFError, ValueError, OSError):
        pass  # the cut: an incomplete chunk or record ends what can be read
    writer.finish()
    return count, last


def _mark_summary(run_dir: Path, count: int, last_log_time_ns: int | None) -> None:
    summary = run_dir / "summary.txt"
    previous = summary.read_text() if summary.is_file() else ""
    note = (f"recovered: the recording was cut short (the bench did not close it); {count} messages up to the "
            f"last whole chunk were rebuilt into an indexed {RECORDING}, the cut file is {RECORDING}{CUT_SUFFIX}\n")
    if previous.startswith("recovered:"):
        return
    if not previous:
        previous = "ended: the bench stopped without writing a summary (killed or lost power)\n"
    summary.write_text(note + previous)
