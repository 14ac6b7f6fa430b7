"""The size limits of docs/architecture.md: no module over 500 lines, no class over 250, no line over 120
characters, in relay/ and tools/ (Python) and xr_client/src/ (JavaScript; protocol.js is generated).

    python tools/shape.py            # prints each offence; exit status 1 when there is one

tests/test_shape.py runs the same check.
"""

from __future__ import annotations

import ast
import re
import sys
from collections.abc import Iterator
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
MAX_MODULE = 500
MAX_CLASS = 250
MAX_LINE = 120
GENERATED = {"xr_client/src/protocol.js"}
_JS_CLASS = re.compile(r"^(?:export\s+)?(?:default\s+)?class\s+(\w+)")


def _files() -> Iterator[Path]:
    for folder in ("relay", "tools"):
        yield from sorted((ROOT / folder).rglob("*.py"))
    yield from sorted((ROOT / "xr_client" / "src").rglob("*.js"))


def _python_classes(text: str) -> Iterator[tuple[str, int]]:
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.ClassDef):
            assert node.end_lineno is not None
            yield node.name, node.end_lineno - node.lineno + 1


def _js_classes(lines: list[str]) -> Iterator[tuple[str, int]]:
    """Top-level classes: from the `class` line to the first later line that closes at column 0."""
    for start, line in enumerate(lines):
        match = _JS_CLASS.match(line)
        if not match:
            continue
        for end in range(start + 1, len(lines)):
            if lines[end].startswith("}"):
                yield match.group(1), end - start + 1
                break


def offences() -> list[str]:
    found: list[str] = []
    for path in _files():
        name = path.relative_to(ROOT).as_posix()
        if name in GENERATED:
            continue
        text = path.read_text(encoding="utf-8")
        lines = text.splitlines()
        if len(lines) > MAX_MODULE:
            found.append(f"{name}: {len(lines)} lines (at most {MAX_MODULE})")
        for number, line in enumerate(lines, 1):
            if len(line) > MAX_LINE:
                found.append(f"{name}:{number}: a line of {len(line)} characters (at most {MAX_LINE})")
        classes = _python_classes(text) if path.suffix == ".py" else _js_classes(lines)
        for cls, size in classes:
            if size > MAX_CLASS:
                found.append(f"{name}: class {cls} has {size} lines (at most {MAX_CLASS})")
    return found


if __name__ == "__main__":
    problems = offences()
    sys.stdout.write("\n".join(problems) or "every module, class and line within its limit")
    sys.stdout.write("\n")
    sys.exit(1 if problems else 0)
