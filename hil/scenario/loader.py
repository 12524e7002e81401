"""Load and validate scenario files; every problem becomes one line naming file, line, field."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml
from pydantic import ValidationError

from hil.scenario.schema import Scenario


@dataclass(frozen=True)
class Problem:
    path: Path
    line: int | None
    field: str
    message: str

    def __str__(self) -> str:
        where = f"{self.path}:{self.line}" if self.line else str(self.path)
        return f"{where}: {self.field}: {self.message}" if self.field else f"{where}: {self.message}"


class ScenarioError(ValueError):
    def __init__(self, problems: list[Problem]) -> None:
        super().__init__("\n".join(str(p) for p in problems))
        self.problems = problems


def _line_of(node: yaml.Node | None, loc: tuple[Any, ...]) -> int | None:
    """The 1-based line of the deepest node along a pydantic error location."""
    line = node.start_mark.line + 1 if node is not None else None
    for key in loc:
        if isinstance(node, yaml.MappingNode):
            match = next((v for k, v in node.value if k.value == key), None)
            if match is None:
                match = next((k for k, _ in node.value if k.value == key), None)
        elif isinstance(node, yaml.SequenceNode) and isinstance(key, int) and key < len(node.value):
            match = node.value[key]
        else:
            match = None
        if match is None:
            break
        node = match
        line = node.start_mark.line + 1
    return line


def _describe(error: dict[str, Any]) -> str:
    kind, found = error["type"], error.get("input")
    if kind == "extra_forbidden":
        return "unknown field; remove it or check its spelling"
    if kind == "missing":
        return "missing; this field is required"
    message = error["msg"]
    if kind == "value_error":  # our validators' messages say what is wrong themselves
        return message.removeprefix("Value error, ")
    if kind.startswith("union_tag") or kind == "literal_error":
        return f"found {found!r}, expected {message.split('Input should be ')[-1]}" if "Input should be" in message else message
    shown = repr(found) if not isinstance(found, dict) else "a mapping"
    expected = message[0].lower() + message[1:] if message else "a valid value"
    return f"found {shown}, expected: {expected}"


def load_scenario(path: Path) -> Scenario:
    """The validated scenario, or ScenarioError with one Problem per mistake."""
    path = Path(path)
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise ScenarioError([Problem(path, None, "", "no such file")]) from None
    except OSError as exc:
        raise ScenarioError([Problem(path, None, "", f"cannot read: {exc.strerror}")]) from None
    try:
        node = yaml.compose(text)
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = mark.line + 1 if mark else None
        raise ScenarioError([Problem(path, line, "", f"not valid YAML: {getattr(exc, 'problem', exc)}")]) from None
    if not isinstance(data, dict):
        raise ScenarioError([Problem(path, 1, "", f"expected a mapping of scenario fields, found {type(data).__name__}")])
    try:
        return Scenario.model_validate(data)
    except ValidationError as exc:
        problems = []
        for error in exc.errors():
            loc = tuple(p for p in error["loc"] if not (isinstance(p, str) and p in _UNION_TAGS))
            field = ".".join(str(p) for p in loc)
            problems.append(Problem(path, _line_of(node, loc), field, _describe(error)))
        raise ScenarioError(problems) from None


_UNION_TAGS = {"hover", "helix", "waypoints", "patrol"}
