"""The package boundaries of docs/architecture.md, read from the source with `ast` (every import, also
the ones inside functions): the plant and the flight-code side never reach into the bench."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
OURS = ("hil", "plant_fmu", "firmware_interface")
# package -> the packages of ours it may import (itself always)
ALLOWED = {"plant_fmu": set(), "firmware_interface": set(), "hil": {"plant_fmu", "firmware_interface"}}


def imported_packages(path: Path) -> set[str]:
    """The top-level packages of ours that a module imports."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            found |= {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.add(node.module.split(".")[0])
    return found & set(OURS)


@pytest.mark.parametrize("package", OURS)
def test_a_package_imports_only_what_the_architecture_allows(package):
    modules = sorted((ROOT / package).rglob("*.py"))
    assert modules
    wrong = {str(m.relative_to(ROOT)): sorted(imported_packages(m) - ALLOWED[package] - {package})
             for m in modules}
    assert {m: p for m, p in wrong.items() if p} == {}


def test_the_rule_sees_an_import_inside_a_function(tmp_path):
    module = tmp_path / "m.py"
    module.write_text("def f():\n    from hil.bench import Bench\n    import plant_fmu.plant\n")
    assert imported_packages(module) == {"hil", "plant_fmu"}
