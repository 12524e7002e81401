"""The bench's exit codes, one definition for the CLI, the runner and the bench."""

from enum import IntEnum


class Exit(IntEnum):
    OK = 0
    EXPECT_FAILED = 1  # expectations not met, or the flight went wrong
    BAD_INPUT = 2  # a scenario, option or run directory the bench cannot use
    BOARD = 3  # the board or its link failed
    INTERNAL = 4  # a bench bug: an error nobody expected (traceback in the run's bench.log)
    DISK_FULL = 5  # the run directory's filesystem filled: the flight stopped, the recording is recoverable
    INTERRUPTED = 130  # Ctrl-C, SIGTERM


EXIT_OK, EXIT_EXPECT_FAILED, EXIT_BAD_INPUT, EXIT_BOARD, EXIT_INTERNAL, EXIT_DISK_FULL, EXIT_INTERRUPTED = (
    Exit.OK, Exit.EXPECT_FAILED, Exit.BAD_INPUT, Exit.BOARD, Exit.INTERNAL, Exit.DISK_FULL, Exit.INTERRUPTED)


def verdict(code: int | None) -> str:
    """The one-word result of a run with this exit code (None: it did not finish)."""
    if code == Exit.OK:
        return "PASS"
    return "FAIL" if code == Exit.EXPECT_FAILED else "ABORTED"
