"""A full disk under the run directory: noticed at the first write that fails for lack of space, whichever file
it was (the recording, whose Rust writer only logs its errors, or the link's tlog), and turned into the end of the
flight (`DiskFull`, a `RunAborted` the bench handles as any other abort: the board is stopped and closed as on
Ctrl-C). A reserve file, made when the run starts and freed when it ends, keeps room for `metrics.json` and
`summary.txt`, which are written before the recording is closed; what the recording holds up to its last whole
chunk stays recoverable (`hil recover`).
"""

from __future__ import annotations

import errno
import logging
import os
import struct
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

from hil.exit_codes import EXIT_DISK_FULL
from hil.loop.pilot import RunAborted

RESERVE_NAME = ".space-reserve"  # removed when the run ends, whatever ends it
RESERVE_BYTES = 256 * 1024  # metrics.json, summary.txt and bench.log take a few tens of kB
NO_SPACE = (errno.ENOSPC, errno.EDQUOT)
_RUST_NO_SPACE = ("StorageFull", "QuotaExceeded")  # how the Rust MCAP writer's logged I/O errors name it
FOXGLOVE_LOGGERS = ("foxglove", "foxglove_py")  # foxglove-sdk's Rust log records arrive on loggers below these
_MCAP_MAGIC = b"\x89MCAP0\r\n"
_RECORD_HEADER = struct.Struct("<BQ")  # opcode, length of the record's body
T = TypeVar("T")


class DiskFull(RunAborted):
    """The run directory's filesystem is full: the flight stops."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason, EXIT_DISK_FULL)


def filesystem_of(path: Path) -> Path:
    """The mount point that holds `path`."""
    path = path.resolve()
    while not os.path.ismount(path) and path != path.parent:
        path = path.parent
    return path


def is_no_space(exc: BaseException) -> bool:
    return isinstance(exc, OSError) and exc.errno in NO_SPACE


class DiskWatch:
    """The run directory's space: its reserve, and the first write that failed for lack of space."""

    def __init__(self, run_dir: Path) -> None:
        self.run_dir = run_dir
        self.failure: str | None = None  # which file could not be written, and why
        self._raised = False
        self._reserve = run_dir / RESERVE_NAME
        self._handler = _NoSpaceLogged(self)
        for name in FOXGLOVE_LOGGERS:
            logging.getLogger(name).addHandler(self._handler)
        try:
            self._reserve.write_bytes(bytes(RESERVE_BYTES))
        except OSError:
            self.close()
            raise

    def failed(self, what: str) -> None:
        """`what` (a file of the run) could not be written for lack of space: the first one is kept."""
        if self.failure is None:
            self.failure = what

    def check(self) -> None:
        """DiskFull once, at the first check after a write failed; later checks pass (the run is ending)."""
        if self.failure is not None and not self._raised:
            self._raised = True
            raise DiskFull(self.reason())

    def reason(self) -> str:
        return (f"disk full: no space left on {filesystem_of(self.run_dir)} writing {self.failure}; the flight was "
                "stopped (hil recover the run directory to read its recording)")

    def attempt(self, name: str, action: Callable[[], object]) -> bool:
        """Run `action`, which writes the file `name`; on a full disk record the failure instead of raising.
        True if it ran through."""
        try:
            action()
        except OSError as exc:
            if not is_no_space(exc):
                raise
            self.failed(name)
            return False
        return True

    def guard(self, write: Callable[[T], None], name: str) -> Callable[[T], None]:
        """`write`, which on a full disk records the failure and from then on writes nothing, never raising."""
        def guarded(data: T) -> None:
            if self.failure is None:
                try:
                    write(data)
                except OSError as exc:
                    if not is_no_space(exc):
                        raise
                    self.failed(name)
        return guarded

    def release(self) -> None:
        """Free the reserve: room for the files written at the end."""
        self._reserve.unlink(missing_ok=True)

    def close(self) -> None:
        self.release()
        for name in FOXGLOVE_LOGGERS:
            logging.getLogger(name).removeHandler(self._handler)


def partial_record_start(path: Path) -> int | None:
    """Where the MCAP file's last record starts if a failed write left it cut short (None: the file ends on a
    whole record), found before anything else is appended. Only the records' headers are read: a long
    recording takes a fraction of a second."""
    size = path.stat().st_size
    with open(path, "rb") as file:
        if file.read(len(_MCAP_MAGIC)) != _MCAP_MAGIC:
            return None
        offset = len(_MCAP_MAGIC)
        while offset < size:
            header = file.read(_RECORD_HEADER.size)
            if header[:len(_MCAP_MAGIC)] == _MCAP_MAGIC and offset + len(_MCAP_MAGIC) == size:
                return None  # the closing magic of a finished file
            if len(header) < _RECORD_HEADER.size:
                return offset
            offset_after = offset + _RECORD_HEADER.size + _RECORD_HEADER.unpack(header)[1]
            if offset_after > size:
                return offset
            file.seek(offset_after)
            offset = offset_after
    return None


class _NoSpaceLogged(logging.Handler):
    """The Rust MCAP writer logs its write errors instead of raising them: a lack of space is the watch's
    failure, and it and every record after it (later writes and the close refused, the consequences) are not
    printed; any other record goes where it would have gone without this handler."""

    def __init__(self, watch: DiskWatch) -> None:
        super().__init__(logging.WARNING)
        self.watch = watch

    def emit(self, record: logging.LogRecord) -> None:
        if any(name in record.getMessage() for name in _RUST_NO_SPACE):
            self.watch.failed("recording.mcap")
        elif self.watch.failure is None and logging.lastResort is not None:
            logging.lastResort.handle(record)
