"""pytest run as a user's CI runs it, in a directory outside the project, with the plugin loaded through its entry
point; the JUnit file it writes read back with the standard library's XML parser."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

from firmware_interface.forkserver import FORKSERVER_ENV

SHORT_HOVER = """\
name: {name}
description: {why}
duration_s: {duration_s}
seed: 1
reference: {{type: hover, altitude_m: 2}}
end: disarm
expect: {{settle_s: 1, max_error_m: {bound_m}}}
"""


def short_hover(directory: Path, name: str, bound_m: float = 1.0, duration_s: float = 2.0,
                why: str = "1 m is loose for the emulator's hover (its errors are ~0.1 m)") -> Path:
    """A scenario of a few seconds: take-off to 2 m, `duration_s` of hover, a disarm where it is."""
    path = directory / f"{name}.yaml"
    why = json.dumps(f"A hover at 2 m for a test of the pytest plugin; {why}")  # a JSON string is YAML
    path.write_text(SHORT_HOVER.format(name=name, why=why, duration_s=duration_s, bound_m=bound_m))
    return path


def run_pytest(cwd: Path, *args: str, timeout_s: float = 600) -> subprocess.CompletedProcess[str]:
    """`python -m pytest ARGS` in `cwd`, without this session's PYTEST_ADDOPTS, its emulator fork server or the
    project's ini file: as a user's CI starts it."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTEST_ADDOPTS", "PYTEST_PLUGINS", FORKSERVER_ENV)}
    return subprocess.run([sys.executable, "-m", "pytest", "-p", "no:cacheprovider", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=timeout_s)


@dataclass(frozen=True)
class Case:
    """One JUnit testcase: its outcome, the text pytest wrote for it, and its properties."""

    outcome: str  # passed, failure, error, skipped
    text: str
    properties: dict[str, str]


def junit_cases(path: Path) -> dict[str, Case]:
    """The file's testcases by `classname::name`."""
    cases = {}
    for case in ET.parse(path).getroot().iter("testcase"):
        found = next((c for c in case if c.tag in ("failure", "error", "skipped")), None)
        properties = {p.get("name", ""): p.get("value", "") for p in case.iter("property")}
        text = "" if found is None else f"{found.get('message', '')}\n{found.text or ''}"
        cases[f"{case.get('classname')}::{case.get('name')}"] = Case(
            "passed" if found is None else found.tag, text, properties)
    return cases
