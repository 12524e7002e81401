"""A PX4 posix build on disk: `bin/px4` and the ROMFS `etc/`.

Both layouts a user has are accepted: PX4-Autopilot's `build/px4_sitl_default` (or
`build/px4_sitl_nolockstep`) and an unpacked binary package with the same two entries.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path


class Px4SetupError(ValueError):
    """The PX4 directory given is not a usable build (bad input, not a board failure)."""


@dataclass(frozen=True)
class Px4Build:
    root: Path

    @property
    def px4(self) -> Path:
        return self.root / "bin" / "px4"

    @property
    def etc(self) -> Path:
        return self.root / "etc"

    def client(self, command: str) -> Path:
        """`bin/px4-<command>`: the client that runs one command inside a running PX4 instance."""
        return self.root / "bin" / f"px4-{command}"

    @classmethod
    def locate(cls, path: str | Path, option: str) -> Px4Build:
        root = Path(path).expanduser().resolve()
        if not root.is_dir():
            raise Px4SetupError(f"{option} {path}: no such directory")
        build = cls(root)
        if not (build.px4.is_file() and os.access(build.px4, os.X_OK)):
            raise Px4SetupError(f"{option} {path}: no executable bin/px4 — expected a PX4 build directory such as "
                                "PX4-Autopilot/build/px4_sitl_default or an unpacked PX4 package")
        if not (build.etc / "init.d-posix" / "rcS").is_file():
            raise Px4SetupError(f"{option} {path}: no etc/init.d-posix/rcS next to bin/px4 (incomplete build?)")
        return build
