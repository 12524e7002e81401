"""`hil recover RUN_DIR`: a recording cut short (power loss, `kill -9`) becomes a complete, indexed MCAP.

The recorder flushes each finished chunk to disk, so a cut file holds every chunk but the one being
filled, and lacks the summary section and footer that indexed readers need. Recovery streams the
records up to the first incomplete one (CRCs checked) and writes them into a new, properly finished
file; the cut original is kept beside it as `recording.mcap.cut`.
"""

from __future__ import annotations

from collections.abc import Iterator
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
PARTIAL_SUFFIX = ".recovering"  # the rebuilt file until it holds something: the original stays where it was
MAGIC = b"\x89MCAP0\r\n"


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


def _check_is_mcap(path: Path) -> None:
    with open(path, "rb") as file:
        start = file.read(len(MAGIC))
    if not start:
        raise RecoverError(f"{path}: empty file, nothing to recover (left as it was)")
    if start != MAGIC:
        raise RecoverError(f"{path}: not an MCAP recording (it does not start with MCAP's magic bytes); left as "
                           "it was")


def recover(run_dir: Path) -> Recovered:
    """Rebuild the run's cut recording; RecoverError, with every file left as it was, when there is nothing
    to rebuild (no file, not MCAP, not one whole message) or the rebuilt file cannot be written."""
    path = run_dir / RECORDING
    if not path.is_file():
        raise RecoverError(f"{run_dir}: no {RECORDING} to recover")
    _check_is_mcap(path)
    if is_complete(path):
        return Recovered(0, None, already_complete=True)
    partial = path.with_name(RECORDING + PARTIAL_SUFFIX)
    try:
        with open(path, "rb") as source, open(partial, "wb") as target:
            count, last = _copy_whole_records(source, target)
    except OSError as exc:
        partial.unlink(missing_ok=True)
        raise RecoverError(f"{partial}: cannot write the rebuilt recording: {exc.strerror or exc}") from None
    if count == 0:
        partial.unlink()
        raise RecoverError(f"{path}: not one whole message in it, nothing to recover (left as it was)")
    path.replace(path.with_name(RECORDING + CUT_SUFFIX))
    partial.replace(path)
    _mark_summary(run_dir, count, last)
    return Recovered(count, last, already_complete=False)


def _whole_records(source: object) -> Iterator[object]:
    """The source's records up to the end or the cut (an incomplete chunk or record ends what can be read)."""
    records = StreamReader(source, validate_crcs=True).records  # type: ignore[arg-type]
    while True:
        try:
            yield next(records)
        except (McapError, EOFError, ValueError, StopIteration, OSError):
            return


def _copy_whole_records(source: object, target: object) -> tuple[int, int | None]:
    """Copy every whole record into a new, indexed file; the target's write errors (a full disk) raise."""
    writer = Writer(target, chunk_size=CHUNK_BYTES, compression=CompressionType.ZSTD)  # type: ignore[arg-type]
    writer.start(profile="", library="hil-bench recover")
    schemas: dict[int, int] = {}
    channels: dict[int, int] = {}
    count, last = 0, None
    for record in _whole_records(source):
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
