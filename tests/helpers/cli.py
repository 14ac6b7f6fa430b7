"""The relay as a user starts it: ``python -m relay`` in a process of its own, read from its first line."""

from __future__ import annotations

import asyncio
import os
import re
import sys

from tests.conftest import ROOT, own_files


async def start_process(*args: str) -> tuple[asyncio.subprocess.Process, str, str]:
    """The relay as a user starts it; returns the process, its base URL and the WebSocket URL with the token."""
    process = await asyncio.create_subprocess_exec(
        sys.executable,
        "-m",
        "relay",
        "--port",
        "0",
        *own_files(*args),
        cwd=ROOT,
        stdout=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.PIPE,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    assert process.stdout is not None
    line = (await asyncio.wait_for(process.stdout.readline(), 30)).decode()
    match = re.search(r"open (http://127\.0\.0\.1:\d+)/#token=(\S+)", line)
    assert match, f"no URL with a token in {line!r}"
    base, token = match.group(1), match.group(2)
    return process, base, base.replace("http", "ws") + f"/ws?token={token}"
