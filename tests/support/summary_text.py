"""Reading a run summary as a user reads it: a field's text runs on over its indented continuation lines."""

from __future__ import annotations


def summary_field(text: str, name: str) -> str:
    """`name: ...` of the summary, its wrapped continuation lines joined; '' if absent."""
    lines = text.splitlines()
    for i, line in enumerate(lines):
        if line.startswith(f"{name}:"):
            parts = [line]
            for follow in lines[i + 1:]:
                if not follow.startswith("    "):
                    break
                parts.append(follow.strip())
            return " ".join(parts)
    return ""
