"""The size limits anyone can check (tools/shape.py): no module over 500 lines, no class over 250, no line over 120
characters, in relay/, tools/ and the client's src/. A module or class past its limit is split by job, never packed:
the formatters (ruff's and prettier's, `make lint`) keep lines within 120 columns, so a packed line fails here too."""

from __future__ import annotations

import sys

from tests.conftest import ROOT


def test_every_module_class_and_line_is_within_its_limit() -> None:
    sys.path.insert(0, str(ROOT / "tools"))
    import shape

    assert shape.offences() == []


def test_the_checker_sees_a_long_class_in_either_language() -> None:
    sys.path.insert(0, str(ROOT / "tools"))
    import shape

    python = "class Big:\n" + "    x = 1\n" * 260
    javascript = "export class Big {\n" + "  x = 1;\n" * 260 + "}\n"
    assert [size for _, size in shape._python_classes(python)] == [261]
    assert [size for _, size in shape._js_classes(javascript.splitlines())] == [262]
