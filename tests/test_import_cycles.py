"""No import cycle in relay/: each module's imports at load time (its top level, and the imports inside its top-level
``if`` and ``try`` blocks) form a graph without a circle. A cycle makes import order load-bearing:
relay/session/protocol.py imported relay/inspection/wire.py at its bottom, which imported protocol's helpers back, and
either worked only because of where the lines stood. Imports inside functions are left out: they run when called, after
every module has loaded, and are how a part reaches an optional dependency (rclpy, zenoh) without making it a
requirement; a second test holds them to the same rule."""

from __future__ import annotations

import ast
from pathlib import Path

from tests.conftest import ROOT

PACKAGE = ROOT / "relay"


def module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def load_time_imports(path: Path, modules: set[str], *, everywhere: bool = False) -> set[str]:
    """The relay modules ``path`` imports when it is loaded (``everywhere``: or in any function of it)."""
    name = module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: set[str] = set()
    for statement in ast.parse(path.read_text(encoding="utf-8")).body:
        nodes = ast.walk(statement) if isinstance(statement, ast.If | ast.Try) or everywhere else [statement]
        for node in nodes:
            if isinstance(node, ast.Import):
                found.update(alias.name for alias in node.names if alias.name in modules)
            elif isinstance(node, ast.ImportFrom):
                base = package.split(".")[: len(package.split(".")) - (node.level - 1)] if node.level else []
                origin = ".".join([*base, *([node.module] if node.module else [])])
                for alias in node.names:
                    target = f"{origin}.{alias.name}"
                    if target in modules:
                        found.add(target)
                    elif origin in modules:
                        found.add(origin)
    found.discard(name)
    return found


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Every strongly connected group of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    groups: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for nxt in sorted(graph[node]):
            if nxt not in index:
                visit(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in on_stack:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            group = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                group.append(member)
                if member == node:
                    break
            if len(group) > 1:
                groups.append(sorted(group))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return groups


def test_the_cycle_finder_finds_a_circle_and_nothing_else() -> None:
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}, "e": set()}
    assert cycles(graph) == [["a", "b", "c"]]


def test_relay_has_no_import_cycle() -> None:
    paths = sorted(PACKAGE.rglob("*.py"))
    modules = {module_name(path) for path in paths}
    graph = {module_name(path): load_time_imports(path, modules) for path in paths}
    assert len(graph) > 100 and graph["relay.session.protocol"] >= {"relay.wire.table", "relay.inspection.wire"}
    assert cycles(graph) == [], "import cycles in relay/: " + "; ".join(" -> ".join(c) for c in cycles(graph))


def test_relay_has_no_import_cycle_through_its_functions_either() -> None:
    """Nor through the imports inside functions: a lazy import that closes a circle hides one (relay/cli/record.py
    imported the ros backend's rclpy loader inside a function, and the ros backend reached record.py for the type
    store; report.py and report_html.py each imported the other, one of them only for typing)."""
    paths = sorted(PACKAGE.rglob("*.py"))
    modules = {module_name(path) for path in paths}
    graph = {module_name(path): load_time_imports(path, modules, everywhere=True) for path in paths}
    assert graph["relay.cli.main"] >= {"relay.cli.record"}  # `xr-relay record` is imported when it is asked for
    assert cycles(graph) == [], "import cycles in relay/: " + "; ".join(" -> ".join(c) for c in cycles(graph))


def test_the_wire_layer_imports_nothing_above_it() -> None:
    """relay/wire/ (fields, declared commands, messages, identifiers, binary frames) is the bottom of the relay:
    features register their commands and messages with it, never the other way round (relay/session/protocol.py
    imported the inspection commands at its bottom, and they imported protocol's helpers back)."""
    paths = sorted(PACKAGE.rglob("*.py"))
    modules = {module_name(path) for path in paths}
    wire = sorted(path for path in paths if module_name(path).startswith("relay.wire"))
    assert len(wire) >= 8
    for path in wire:
        above = {m for m in load_time_imports(path, modules, everywhere=True) if not m.startswith("relay.wire")}
        assert above <= {"relay.errors"}, f"{module_name(path)} imports {sorted(above)}"


def test_no_test_module_imports_another() -> None:
    """What tests share is in tests/helpers/ (and the conftests): seven browser tests once imported helpers from other
    test modules, which made a test file a library whose tests ran again wherever it was imported."""
    paths = sorted((ROOT / "tests").rglob("*.py"))
    modules = {module_name(path) for path in paths}
    tests = {m for m in modules if m.rpartition(".")[2].startswith("test_")}
    assert len(tests) > 100
    shared = {
        module_name(path): sorted(load_time_imports(path, modules, everywhere=True) & tests)
        for path in paths
        if load_time_imports(path, modules, everywhere=True) & tests
    }
    assert shared == {}, f"test modules imported as libraries: {shared}"
