"""The package boundaries of docs/architecture.md, read from the source with `ast` (every import, also the ones
inside functions): each subpackage imports only the layers below it, and no two of them import each other."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
OURS = ("hil", "plant_fmu", "firmware_interface")
FI, EMULATOR = "firmware_interface", "firmware_interface.emulator"
_BELOW_LOOP = {"hil.boards", "hil.host", "hil.scenario", "hil.sensors", "hil.exit_codes", "plant_fmu", FI}
# what a front end (the command line, the pytest plugin) may import: every part of the bench below it
_BENCH = {"hil.exit_codes", "hil.channels", "hil.host", "hil.sensors", "hil.scenario", "hil.boards", "hil.loop",
          "hil.judge", "hil.pilots", "hil.outputs", "hil.reports", "hil.run", "hil.sweep", "plant_fmu", FI, EMULATOR}
# unit -> the units of ours it may import (itself always). A unit is a subpackage of `hil` (hil.loop), a leaf
# module at hil's root (hil.exit_codes), the emulator, or a top-level package.
ALLOWED: dict[str, set[str]] = {
    "plant_fmu": set(),
    FI: set(),  # the link, the codec, the board session: never the emulator, which is firmware of its own
    EMULATOR: {FI},
    "hil": set(),
    "hil.exit_codes": set(),
    "hil.channels": {EMULATOR},  # the controllers' published internals name the estimates channel's fields
    "hil.host": {"hil.exit_codes"},
    "hil.sensors": {FI},
    "hil.scenario": {"hil.sensors", "hil.channels", "plant_fmu", FI, EMULATOR},  # validates the emulator's config
    "hil.boards": {"hil.host", "hil.scenario", "hil.sensors", FI},
    "hil.loop": _BELOW_LOOP | {EMULATOR},  # the emulator's geometry and controller names decode board messages
    "hil.judge": {"hil.loop", "hil.scenario", "hil.exit_codes", "plant_fmu", FI, EMULATOR},
    "hil.pilots": _BELOW_LOOP | {"hil.loop", "hil.judge"},
    "hil.outputs": {"hil.loop", "hil.channels", "hil.scenario", "hil.host", "hil.exit_codes", FI, EMULATOR},
    "hil.reports": {"hil.outputs", "hil.channels", "hil.judge", "hil.scenario", "hil.exit_codes", FI, EMULATOR},
    "hil.run": _BELOW_LOOP | {"hil.loop", "hil.judge", "hil.pilots", "hil.outputs", "hil.channels"},
    "hil.sweep": {"hil.run", "hil.scenario", "hil.boards", "hil.host", "hil.exit_codes"},  # a worker's fork server
    "hil.app": {"hil", *_BENCH},
    "hil.testing": _BENCH,  # the pytest plugin: a front end beside the command line, never importing it
    "hil.__main__": {"hil.app"},
}


def unit_of(dotted: str) -> str | None:
    """The unit a dotted module name belongs to (None: not ours)."""
    parts = dotted.split(".")
    if parts[0] not in OURS:
        return None
    if parts[0] == "hil" and len(parts) > 1:
        return f"hil.{parts[1]}"
    if parts[:2] == ["firmware_interface", "emulator"]:
        return EMULATOR
    return parts[0]


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imported_units(path: Path) -> set[str]:
    """The units of ours that a module imports (`from hil import x` counts as hil.x)."""
    found: set[str | None] = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            found |= {unit_of(alias.name) for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found |= ({unit_of(f"{node.module}.{alias.name}") for alias in node.names}
                      if node.module in OURS else {unit_of(node.module)})
    return {u for u in found if u is not None}


def import_graph() -> dict[str, set[str]]:
    """unit -> the other units its modules import."""
    graph: dict[str, set[str]] = {}
    for package in OURS:
        for path in sorted((ROOT / package).rglob("*.py")):
            unit = unit_of(module_name(path))
            assert unit is not None
            graph.setdefault(unit, set()).update(imported_units(path) - {unit})
    return graph


def wrong_imports(graph: dict[str, set[str]]) -> dict[str, list[str]]:
    return {unit: sorted(imports - ALLOWED.get(unit, set())) for unit, imports in graph.items()
            if imports - ALLOWED.get(unit, set())}


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Every cycle of the graph, found by depth-first search from each unit (each cycle once per start)."""
    found = []

    def visit(unit: str, path: list[str]) -> None:
        for nxt in sorted(graph.get(unit, ())):
            if nxt == path[0]:
                found.append([*path, nxt])
            elif nxt not in path and nxt > path[0]:
                visit(nxt, [*path, nxt])

    for start in sorted(graph):
        visit(start, [start])
    return found


def test_every_unit_of_the_code_has_a_rule():
    assert set(import_graph()) - set(ALLOWED) == set()


def test_each_package_imports_only_the_layers_below_it():
    assert wrong_imports(import_graph()) == {}


def test_no_two_packages_import_each_other():
    assert cycles(import_graph()) == []


def test_the_rule_sees_an_import_inside_a_function(tmp_path):
    module = tmp_path / "m.py"
    module.write_text("def f():\n    from hil.loop.stepper import Stepper\n    import plant_fmu.plant\n"
                      "    from hil import exit_codes\n")
    assert imported_units(module) == {"hil.loop", "plant_fmu", "hil.exit_codes"}


def test_the_rule_refuses_the_emulator_outside_the_emulator(tmp_path):
    """What the earlier rule missed: firmware_interface/board_messages.py imported the emulator's registry."""
    module = tmp_path / "board_messages.py"
    module.write_text("from firmware_interface.emulator.control.registry import INTERNAL_KEYS_BY_WIRE_NAME\n")
    assert wrong_imports({FI: imported_units(module)}) == {FI: [EMULATOR]}


@pytest.mark.parametrize(("graph", "expected"), [
    ({"a": {"b"}, "b": {"c"}, "c": set()}, []),
    ({"a": {"b"}, "b": {"a"}}, [["a", "b", "a"]]),
    ({"a": {"b"}, "b": {"c"}, "c": {"a"}}, [["a", "b", "c", "a"]]),
])
def test_cycles_are_found(graph, expected):
    assert cycles(graph) == expected
