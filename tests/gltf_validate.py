"""Run the Khronos glTF validator (npm ``gltf-validator``, installed in xr_client/) on bytes or a file.

    report = validate_glb(path_or_bytes)
    assert report["issues"]["numErrors"] == 0, issues_text(report)

The validator is JavaScript: ``tools/validate_gltf.mjs`` feeds the bytes to its ``validateBytes`` API in a
``node`` subprocess and prints the report as JSON. :func:`unavailable_reason` says why validation cannot
run (no node, packages not installed) so that a test can skip with that reason instead of failing.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
SCRIPT = ROOT / "tools" / "validate_gltf.mjs"
PACKAGE = ROOT / "xr_client" / "node_modules" / "gltf-validator"
#: Seconds allowed for one validation; a multi-megabyte GLB takes about one second on a busy dev box.
TIMEOUT = 120.0


def unavailable_reason() -> str | None:
    """Why the validator cannot run here (a sentence for ``pytest.skip``), or None when it can."""
    if shutil.which("node") is None:
        return "node is not on PATH (the Khronos glTF validator is a Node.js package)"
    if not (PACKAGE / "package.json").is_file():
        return f"npm package gltf-validator is not installed at {PACKAGE} (run `make setup`)"
    return None


def validate_glb(asset: bytes | str | os.PathLike[str]) -> dict[str, Any]:
    """Validate a GLB (or glTF JSON) given as bytes or a path; return the validator's report.

    The report is the validator's own object: ``issues.numErrors``, ``issues.numWarnings``,
    ``issues.messages`` (each with ``code``, ``message``, ``severity``, ``pointer``) and ``info``.
    Every issue is listed (no truncation) and the report has no timestamp.

    Raises:
        RuntimeError: the validator is unavailable or could not process the input at all (for example
            bytes that are neither glTF nor GLB); the message includes its stderr.
    """
    reason = unavailable_reason()
    if reason is not None:
        raise RuntimeError(reason)
    data = asset if isinstance(asset, bytes) else Path(asset).read_bytes()
    proc = subprocess.run(
        ["node", str(SCRIPT), "-"],
        input=data,
        capture_output=True,
        timeout=TIMEOUT,
        check=False,
    )
    # Exit status 1 only means "the report has errors": the report is still there to return.
    if proc.returncode not in (0, 1) or not proc.stdout:
        raise RuntimeError(
            f"glTF validator failed (exit {proc.returncode}): {proc.stderr.decode(errors='replace').strip()}"
        )
    report: dict[str, Any] = json.loads(proc.stdout)
    return report


def issues_text(report: dict[str, Any], limit: int = 20) -> str:
    """The report's issues as readable lines, for assertion messages."""
    messages = report.get("issues", {}).get("messages", [])
    lines = [
        f"{m.get('code')} (severity {m.get('severity')}) at {m.get('pointer')}: {m.get('message')}" for m in messages
    ]
    more = f"\n... and {len(lines) - limit} more" if len(lines) > limit else ""
    return "\n".join(lines[:limit]) + more
