"""A PX4 posix build on disk: `bin/px4` and the ROMFS `etc/`.

Both layouts a user has are accepted: PX4-Autopilot's `build/px4_sitl_default` (or
`build/px4_sitl_nolockstep`) and an unpacked binary package with the same two entries.
"""

from __future__ import annotations

import os
import tarfile
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


# PX4-Autopilot's build directory name, and the binary package's file pattern, for each kind of build
LAYOUTS = {"sitl": ("px4_sitl_default", "px4-sitl-*.tar.gz"),
           "hitl": ("px4_sitl_nolockstep", "px4-hitl-nolockstep-*.tar.gz")}


def unpack_inside(package: Path, target: Path) -> None:
    """Unpack the tar `package` into `target` once every member's path and link are known to stay inside it (a
    Px4SetupError names the first that does not); with PEP 706's "tar" filter too where Python has it (3.11.4 on:
    Debian 12's CPython 3.11.2, which the Makefile prefers for its speed, has not)."""
    with tarfile.open(package) as archive:
        _check_members(package, archive, target)
        if hasattr(tarfile, "tar_filter"):
            archive.extractall(target, filter="tar")
        else:
            archive.extractall(target)


def _check_members(package: Path, archive: tarfile.TarFile, target: Path) -> None:
    """A member's own path, a symbolic link's target (from the member's folder) and a hard link's must resolve
    inside `target`, and no member may be a device: stricter than the "tar" filter (PEP 706's "data" filter checks
    links and devices too); a PX4 package has relative links inside itself and no devices."""
    root = target.resolve()
    for member in archive.getmembers():
        paths = [member.name]
        if member.issym():
            paths.append(os.path.join(os.path.dirname(member.name), member.linkname))
        elif member.islnk():
            paths.append(member.linkname)
        if member.isdev() or any(not (root / path).resolve().is_relative_to(root) for path in paths):
            raise Px4SetupError(f"{package}: {member.name} would be unpacked outside {target}")


def find_build(root: Path, kind: str, scratch: Path) -> Path:
    """The `kind` build under `root`: `root/px4_sitl_default` (PX4-Autopilot/build) or a package
    `root/px4-sitl-*.tar.gz` unpacked into `scratch`. Raises Px4SetupError when there is neither."""
    build_dir, pattern = LAYOUTS[kind]
    if (root / build_dir / "bin" / "px4").is_file():
        return root / build_dir
    packages = sorted(root.glob(pattern))
    if not packages:
        raise Px4SetupError(f"{root}: neither {build_dir}/bin/px4 nor a {pattern} package")
    target = scratch / kind
    target.mkdir(parents=True, exist_ok=True)
    unpack_inside(packages[-1], target)
    for candidate in (target, *sorted(p for p in target.iterdir() if p.is_dir())):
        if (candidate / "bin" / "px4").is_file():
            return candidate
    raise Px4SetupError(f"{packages[-1]}: no bin/px4 in the package")
