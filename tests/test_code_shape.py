"""The code's shape, measured (CONTRIBUTING.md, "Checking a change"): no function longer than 60 lines and
none with a cyclomatic complexity graded worse than C by radon, in the three packages."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest
from radon.complexity import cc_rank, cc_visit

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("hil", "plant_fmu", "firmware_interface")
MAX_LINES = 60
WORST_GRADE = "C"  # radon: A 1-5, B 6-10, C 11-20, D 21-30, ...


def modules() -> list[Path]:
    return sorted(p for package in PACKAGES for p in (ROOT / package).rglob("*.py"))


def test_no_function_is_longer_than_60_lines():
    long = []
    for path in modules():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                lines = node.end_lineno - node.lineno + 1 if node.end_lineno else 0
                if lines > MAX_LINES:
                    long.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name} ({lines} lines)")
    assert long == []


def test_no_function_is_more_complex_than_grade_c():
    complex_ = [f"{path.relative_to(ROOT)}:{block.lineno} {block.fullname} ({cc_rank(block.complexity)} "
                f"{block.complexity})"
                for path in modules() for block in cc_visit(path.read_text())
                if cc_rank(block.complexity) > WORST_GRADE]
    assert complex_ == []


@pytest.mark.parametrize(("complexity", "grade"), [(5, "A"), (10, "B"), (20, "C"), (21, "D")])
def test_the_grades_are_radons(complexity, grade):
    assert cc_rank(complexity) == grade
