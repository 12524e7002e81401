"""Output folders checked before anything starts: one that cannot be written is bad input, said in one line,
not a traceback from the first file a run or a sweep writes."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path


def unwritable(folder: Path) -> str | None:
    """Why files cannot be made in `folder` (made if missing), or None when they can. Probed with a temporary
    file in the nearest folder that exists (removed at once), so that a read-only mount is found as root too;
    nothing is left behind."""
    if folder.exists() and not folder.is_dir():
        return "exists and is not a directory"
    existing = next(p for p in (folder, *folder.parents) if p.exists())
    if not existing.is_dir():
        return f"{existing} is a file"
    try:
        with tempfile.TemporaryFile(dir=existing):
            pass
    except OSError as exc:
        return f"cannot be written ({existing}: {exc.strerror or exc})"
    return None if os.access(existing, os.W_OK | os.X_OK) else f"cannot be written ({existing})"
