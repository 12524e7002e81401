"""The code's shape, measured (CONTRIBUTING.md, "Checking a change"): no module longer than 400 lines, no function
longer than 60 lines and none with a cyclomatic complexity graded worse than C by radon, in the three packages; the
loop under 250 lines."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest
from radon.complexity import cc_rank, cc_visit

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("hil", "plant_fmu", "firmware_interface")
MAX_LINES = 60
MAX_MODULE_LINES = 400
MAX_LOOP_LINES = 250  # the step loop (hil/loop/stepper.py): it only steps, sends, waits and hands frames on
WORST_GRADE = "C"  # radon: A 1-5, B 6-10, C 11-20, D 21-30, ...


def modules() -> list[Path]:
    return sorted(p for package in PACKAGES for p in (ROOT / package).rglob("*.py"))


def test_no_module_is_longer_than_400_lines():
    long = {str(path.relative_to(ROOT)): n for path in modules()
            if (n := len(path.read_text().splitlines())) > MAX_MODULE_LINES}
    assert long == {}


def test_the_loop_stays_small():
    assert len((ROOT / "hil" / "loop" / "stepper.py").read_text().splitlines()) <= MAX_LOOP_LINES


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
