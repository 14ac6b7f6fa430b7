"""docs/architecture.md names files and symbols; each must exist, where it says. It was stale at birth (``encode`` and
``pose_message`` named in protocol.py, which never held them): a renamed or moved part fails here, not later in a
reader's hands."""

from __future__ import annotations

import ast
import re
from pathlib import Path

from tests.conftest import ROOT

DOC = ROOT / "docs" / "architecture.md"
#: Where a bare file name (``nav2_goals.py``) may be: the project's Python and the client.
SEARCHED = ("relay", "tools", "xr_client/src")
_CODE = re.compile(r"`([^`\s]+)`")
_FILE = re.compile(r"\.(yaml|yml|md|json|glb|gltf|html|css|toml|txt)$")
_SYMBOL = re.compile(r"^_?[A-Za-z][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)?$")


def defined(path: Path) -> set[str]:
    """Names defined in a Python module: functions, classes, their methods (``Class.method``), module constants."""
    names: set[str] = set()
    for node in ast.parse(path.read_text(encoding="utf-8")).body:
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            names.add(node.name)
        elif isinstance(node, ast.ClassDef):
            names.add(node.name)
            names.update(
                f"{node.name}.{m.name}" for m in node.body if isinstance(m, ast.FunctionDef | ast.AsyncFunctionDef)
            )
        elif isinstance(node, ast.Assign | ast.AnnAssign):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            names.update(t.id for t in targets if isinstance(t, ast.Name))
    return names


def files_named(token: str) -> list[Path]:
    if "*" in token:
        return sorted(ROOT.glob(token))
    if "/" in token:
        return [ROOT / token] if (ROOT / token).exists() else []
    return [p for folder in SEARCHED for p in (ROOT / folder).rglob(token)]


def problems(text: str) -> list[str]:
    found = []
    for number, line in enumerate(text.splitlines(), 1):
        tokens = _CODE.findall(line)
        files = [t for t in tokens if re.search(r"\.(py|js)$|/$", t) and not t.startswith(("-", "/"))]
        paths = []
        for token in files:
            hits = files_named(token)
            if not hits:
                found.append(f"line {number}: {token} does not exist")
            paths += [p for p in hits if p.suffix == ".py"]
        if not paths:
            continue  # symbols are checked where a row names the module that holds them
        names = set().union(*(defined(p) for p in paths))
        for token in tokens:
            if token in files or not _SYMBOL.match(token) or _FILE.search(token):
                continue  # file names (`robots.yaml`), and plain words set in code type (`clock`, `error`)
            if token.islower() and "_" not in token and "." not in token:
                continue
            if token not in names:
                found.append(f"line {number}: {token} is not defined in {', '.join(p.name for p in paths)}")
    return found


def test_the_checker_finds_a_missing_file_and_a_symbol_in_the_wrong_module() -> None:
    text = (
        "| x | `relay/fleet/state.py` `FleetState.on_pose` |\n"
        "| y | `relay/session/protocol.py` `pose_message` |\n"
        "| z | `relay/nowhere.py` |"
    )
    assert problems(text) == [
        "line 2: pose_message is not defined in protocol.py",
        "line 3: relay/nowhere.py does not exist",
    ]


def test_every_file_and_symbol_docs_architecture_names_exists_where_it_says() -> None:
    assert problems(DOC.read_text(encoding="utf-8")) == []
