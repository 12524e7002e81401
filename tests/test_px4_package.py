"""A PX4 binary package is unpacked only when none of its members leads outside the scratch directory (what PEP 706's
"data" filter refuses, checked by the bench itself on every Python: Debian 12's 3.11.2 has no filters)."""

from __future__ import annotations

import io
import tarfile
from pathlib import Path

import pytest

from hil.boards.px4.build import Px4SetupError, find_build


def _package(root: Path, extra: tarfile.TarInfo | None = None) -> Path:
    """A minimal px4-sitl package: bin/px4, a client link to it, and `extra`."""
    path = root / "px4-sitl-v0-linux-x86_64.tar.gz"
    with tarfile.open(path, "w:gz") as archive:
        px4 = tarfile.TarInfo("pkg/bin/px4")
        px4.size, px4.mode = 3, 0o755
        archive.addfile(px4, io.BytesIO(b"elf"))
        client = tarfile.TarInfo("pkg/bin/px4-shutdown")
        client.type, client.linkname = tarfile.SYMTYPE, "px4"
        archive.addfile(client)
        if extra is not None:
            archive.addfile(extra, io.BytesIO(b"x" * extra.size) if extra.isfile() else None)
    return path


def _member(name: str, kind: bytes = tarfile.REGTYPE, linkname: str = "") -> tarfile.TarInfo:
    info = tarfile.TarInfo(name)
    info.type, info.linkname, info.size = kind, linkname, 1 if kind == tarfile.REGTYPE else 0
    return info


def test_a_package_unpacks_with_its_links(tmp_path):
    _package(tmp_path)
    build = find_build(tmp_path, "sitl", tmp_path / "scratch")
    assert build == tmp_path / "scratch" / "sitl" / "pkg"
    assert (build / "bin" / "px4-shutdown").resolve() == (build / "bin" / "px4").resolve()


@pytest.mark.parametrize("member", [
    _member("../outside"),
    _member("pkg/../../outside"),
    _member("/tmp/absolute"),
    _member("pkg/bin/escape", tarfile.SYMTYPE, "../../../.."),
    _member("pkg/bin/passwd", tarfile.SYMTYPE, "/etc/passwd"),
    _member("pkg/bin/hard", tarfile.LNKTYPE, "../../outside"),
    _member("pkg/dev/null", tarfile.CHRTYPE),
], ids=lambda m: m.name)
def test_a_member_leading_outside_is_refused_and_nothing_is_unpacked(tmp_path, member):
    _package(tmp_path, member)
    scratch = tmp_path / "scratch"
    with pytest.raises(Px4SetupError, match=rf"{member.name} would be unpacked outside "):
        find_build(tmp_path, "sitl", scratch)
    assert list((scratch / "sitl").iterdir()) == []
    assert not (tmp_path / "outside").exists()
