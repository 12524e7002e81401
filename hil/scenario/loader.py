"""Load and validate scenario files; every problem becomes one line naming file, line, field.

Loading is bounded before anything can take long or recurse deep: the file's size (MAX_BYTES), its text
(UTF-8), and, from the YAML event stream alone, the nesting depth (MAX_DEPTH) and the node count with every
alias expanded (MAX_NODES: a billion-laughs file is refused before it is built). A key given twice in a
mapping is an error (YAML would keep the last one silently). At most MAX_PROBLEMS problems are listed.
`read_yaml` is the bench's one bounded YAML reader: sweep files are read through it too.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

import yaml
from pydantic import ValidationError
from pydantic_core import ErrorDetails

from hil.scenario.expressions import echo
from hil.scenario.fields import SCENARIO_DIR
from hil.scenario.schema import CHECK_ERROR, Scenario

MAX_BYTES = 1_000_000  # a scenario or a sweep is a few kB
MAX_DEPTH = 20  # nested mappings and lists; a scenario or a sweep needs 5
MAX_NODES = 100_000  # with aliases expanded; a scenario has a few hundred
MAX_PROBLEMS = 20
MAX_FIELD_CHARS = 120  # a line's field and message are cut there, whatever they quote
MAX_MESSAGE_CHARS = 500
_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
_MERGE_TAG = "tag:yaml.org,2002:merge"

YamlPath = tuple[str | int, ...]
T = TypeVar("T")


@dataclass(frozen=True)
class Problem:
    path: Path
    line: int | None
    field: str
    message: str

    def __str__(self) -> str:
        """One line, however long or multi-line the key or value it names."""
        where = f"{self.path}:{self.line}" if self.line else str(self.path)
        message = f"{self.message:.{MAX_MESSAGE_CHARS}}"
        text = f"{where}: {self.field:.{MAX_FIELD_CHARS}}: {message}" if self.field else f"{where}: {message}"
        return text.replace("\r", "\\r").replace("\n", "\\n")


class ScenarioError(ValueError):
    """A file's problems, at most MAX_PROBLEMS lines: beyond that, the first ones and a line saying how many
    more there are (5000 unknown keys do not print 5000 lines)."""

    def __init__(self, problems: list[Problem]) -> None:
        shown = problems
        if len(problems) > MAX_PROBLEMS:
            hidden = len(problems) - (MAX_PROBLEMS - 1)
            shown = [*problems[:MAX_PROBLEMS - 1], Problem(problems[0].path, None, "", f"… and {hidden} more problems")]
        super().__init__("\n".join(str(p) for p in shown))
        self.problems = shown


def _fail(path: Path, message: str, line: int | None = None) -> ScenarioError:
    return ScenarioError([Problem(path, line, "", message)])


def _read_text(path: Path) -> str:
    """The file's text: at most MAX_BYTES read, decoded as UTF-8 (a byte-order mark allowed), no NUL."""
    try:
        with path.open("rb") as file:
            raw = file.read(MAX_BYTES + 1)
    except FileNotFoundError:
        raise _fail(path, "no such file") from None
    except OSError as exc:
        raise _fail(path, f"cannot read: {exc.strerror or exc}") from None
    if len(raw) > MAX_BYTES:
        raise _fail(path, f"larger than {MAX_BYTES:,} bytes; a scenario or a sweep is a few kB of YAML")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise _fail(path, f"not UTF-8 text (byte 0x{raw[exc.start]:02x} at offset {exc.start}); save it as "
                          f"UTF-8", raw.count(b"\n", 0, exc.start) + 1) from None
    if "\0" in text:
        raise _fail(path, "not UTF-8 text: it contains NUL bytes (a binary file?)",
                    text.count("\n", 0, text.index("\0")) + 1)
    return text


def _size_problem(text: str) -> tuple[int, str] | None:
    """(line, what is wrong) if the YAML nests deeper than MAX_DEPTH or expands to more than MAX_NODES nodes,
    found from the event stream alone: nothing is built, so neither recursion nor an alias bomb can run."""
    expanded: dict[str, int] = {}  # anchor -> its node's size with aliases expanded
    open_collections: list[tuple[str | None, int]] = []  # (anchor, total when it opened)
    total = 0
    for event in yaml.parse(text, Loader=_LOADER):
        line = event.start_mark.line + 1 if event.start_mark is not None else 0
        if isinstance(event, yaml.AliasEvent) and event.anchor is not None:
            if any(anchor == event.anchor for anchor, _ in open_collections):
                return line, f"alias *{event.anchor} is inside its own anchor &{event.anchor} (a recursive structure)"
            total += expanded.get(event.anchor, 1)  # an undefined alias: the composer says so
        elif isinstance(event, (yaml.ScalarEvent, yaml.CollectionStartEvent)):
            total += 1
            if isinstance(event, yaml.CollectionStartEvent):
                open_collections.append((event.anchor, total))
                if len(open_collections) > MAX_DEPTH:
                    return line, f"nested deeper than {MAX_DEPTH} levels; a scenario or a sweep needs about 5"
            elif event.anchor is not None:
                expanded[event.anchor] = 1
        elif isinstance(event, yaml.CollectionEndEvent):
            anchor, opened_at = open_collections.pop()
            if anchor is not None:
                expanded[anchor] = total - opened_at + 1
        if total > MAX_NODES:
            return line, (f"more than {MAX_NODES:,} YAML nodes with aliases expanded (an alias bomb?); "
                          f"a scenario or a sweep has a few hundred")
    return None


def _index(root: yaml.Node | None) -> dict[YamlPath, yaml.Node]:
    """Every node of the document by its path of mapping keys (strings) and list indices (ints)."""
    index: dict[YamlPath, yaml.Node] = {}
    stack: list[tuple[YamlPath, yaml.Node]] = [((), root)] if root is not None else []
    while stack:
        path, node = stack.pop()
        index[path] = node
        if isinstance(node, yaml.MappingNode):
            stack.extend(((*path, str(k.value)), v) for k, v in node.value if isinstance(k, yaml.ScalarNode))
        elif isinstance(node, yaml.SequenceNode):
            stack.extend(((*path, i), v) for i, v in enumerate(node.value))
    return index


def _duplicate_keys(path: Path, index: dict[YamlPath, yaml.Node]) -> list[Problem]:
    """One problem per key given a second time in the same mapping."""
    problems, seen = [], set()
    for where, node in index.items():
        if not isinstance(node, yaml.MappingNode) or id(node) in seen:
            continue
        seen.add(id(node))  # a mapping reached through an alias is checked once
        first: dict[tuple[str, str], int] = {}
        for key, _ in node.value:
            if not isinstance(key, yaml.ScalarNode) or key.tag == _MERGE_TAG:
                continue
            line = key.start_mark.line + 1
            if (key.tag, key.value) in first:
                problems.append(Problem(path, line, ".".join(map(str, (*where, key.value))),
                                        f"duplicate key (first given at line {first[key.tag, key.value]}); "
                                        f"keep one, YAML would silently use the last"))
            first.setdefault((key.tag, key.value), line)
    return sorted(problems, key=lambda p: p.line or 0)


def _yaml(path: Path, step: Callable[[], T]) -> T:
    """`step`'s result, its YAML errors made a ScenarioError."""
    try:
        return step()
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = mark.line + 1 if mark else None
        raise _fail(path, f"not valid YAML: {getattr(exc, 'problem', None) or exc}", line) from None
    except ValueError as exc:  # a value YAML accepts but Python cannot hold, e.g. an integer of 5000 digits
        raise _fail(path, f"not valid YAML: {exc}") from None


def read_yaml(path: Path) -> tuple[dict[YamlPath, yaml.Node], Any]:
    """The document's nodes by path (for line numbers) and its data, or ScenarioError: the file read within
    every bound above, a duplicate key refused."""
    path = Path(path)
    text = _read_text(path)
    too_big = _yaml(path, lambda: _size_problem(text))
    if too_big:
        raise _fail(path, too_big[1], too_big[0])
    loader = _LOADER(text)
    try:
        node = _yaml(path, loader.get_single_node)
        index = _index(node)
        duplicates = _duplicate_keys(path, index)
        if duplicates:
            raise ScenarioError(duplicates)
        return index, _yaml(path, lambda: loader.construct_document(node)) if node is not None else None
    finally:
        loader.dispose()


def _locate(index: dict[YamlPath, yaml.Node], loc: tuple[Any, ...], kind: str) -> tuple[int | None, YamlPath]:
    """The line of the deepest YAML node along a pydantic error location, and the location as the file
    spells it. A key not in the file is a field left at its default, or a label pydantic adds for a union's
    branch ('hover', 'float', '[key]'), which is left out: labels are never last in the location of a
    missing field, and never in the location of our own checks."""
    found: YamlPath = ()
    kept: list[str | int] = []
    for position, key in enumerate(loc):
        step = next((s for s in ((*found, key), (*found, str(key))) if s in index), None)
        if step is not None:
            found = step
        if step is not None or kind == CHECK_ERROR or (kind == "missing" and position == len(loc) - 1):
            kept.append(key)
    node = index.get(found)
    return (node.start_mark.line + 1 if node is not None else None), tuple(kept)


def describe(error: ErrorDetails) -> str:
    """What is wrong with the value, in words: what was found and what is expected."""
    kind, found = error["type"], error.get("input")
    if kind == "extra_forbidden":
        return "unknown field; remove it or check its spelling"
    if kind == "missing":
        return "missing; this field is required"
    message = error["msg"]
    if kind in ("value_error", CHECK_ERROR):  # our validators' messages say what is wrong themselves
        return message.removeprefix("Value error, ")
    if kind == "union_tag_not_found":
        return f"{error['ctx']['discriminator']} is missing; it says which kind this is"
    if kind == "union_tag_invalid":
        return f"found {echo(error['ctx']['tag'])}, expected one of {error['ctx']['expected_tags']}"
    if kind == "literal_error":
        return f"found {echo(found)}, expected {message.removeprefix('Input should be ')}"
    shown = echo(found) if not isinstance(found, dict) else "a mapping"
    expected = message[0].lower() + message[1:] if message else "a valid value"
    return f"found {shown}, expected: {expected}"


def located_problems(path: Path, index: dict[YamlPath, yaml.Node], exc: ValidationError) -> list[Problem]:
    """One problem per error, in the file's order, with the line of the field it names."""
    problems = []
    for error in exc.errors(include_url=False):
        line, loc = _locate(index, error["loc"], error["type"])
        problems.append(Problem(path, line, ".".join(str(p) for p in loc), describe(error)))
    return sorted(problems, key=lambda p: p.line or 0)


def load_scenario(path: Path) -> Scenario:
    """The validated scenario, or ScenarioError with one Problem per mistake."""
    path = Path(path)
    index, data = read_yaml(path)
    if not isinstance(data, dict):
        found = "an empty file" if data is None else type(data).__name__
        raise _fail(path, f"expected a mapping of scenario fields, found {found}", 1)
    try:
        return Scenario.model_validate(data, context={SCENARIO_DIR: path.parent})
    except ValidationError as exc:
        raise ScenarioError(located_problems(path, index, exc)) from None
