"""A robot on the other side of DDS: tests/ros_peer.py in a process of its own (this test's ROS domain, from the
environment), and the JSON lines it prints."""

from __future__ import annotations

import asyncio
import json
import os
import sys
import time
from pathlib import Path
from typing import Any

from tests.conftest import ROOT

#: How long a peer may take to say it is ready: importing rclpy and OpenCV and making its DDS participant take
#: 1-2 s on an idle machine, and over 30 s were seen with the suite's workers and a CPU hog sharing two cores.
READY_TIMEOUT = 120.0


class Peer:
    """A tests/ros_peer.py process and the JSON lines it prints."""

    def __init__(self, process: asyncio.subprocess.Process) -> None:
        self.process = process
        self.lines: list[dict[str, Any]] = []
        self._reader = asyncio.ensure_future(self._read())

    async def _read(self) -> None:
        assert self.process.stdout is not None
        async for raw in self.process.stdout:
            self.lines.append(json.loads(raw))

    async def wait_for(self, predicate: Any, timeout: float = 10.0) -> dict[str, Any]:
        """The first line (from the start) that ``predicate`` accepts; fails at once should the peer exit first."""
        deadline = time.monotonic() + timeout
        index = 0
        while time.monotonic() < deadline:
            while index < len(self.lines):
                line = self.lines[index]
                index += 1
                if predicate(line):
                    return line
            if self._reader.done() and index == len(self.lines):
                status = await self.process.wait()
                raise AssertionError(f"the peer exited (status {status}) before printing that; last: {self.lines[-3:]}")
            await asyncio.sleep(0.02)
        raise TimeoutError(f"peer printed nothing matching within {timeout} s; last: {self.lines[-3:]}")

    async def stop(self) -> None:
        if self.process.returncode is None:
            self.process.kill()
            await self.process.wait()
        self._reader.cancel()


async def start_peer(spec: dict[str, Any], tmp_path: Path) -> Peer:
    """The peer publishing and echoing what ``spec`` says (tests/ros_peer.py), once it says it is ready."""
    path = tmp_path / f"peer-{time.monotonic_ns()}.json"
    path.write_text(json.dumps(spec))
    process = await asyncio.create_subprocess_exec(
        sys.executable, str(ROOT / "tests" / "ros_peer.py"), str(path),
        stdout=asyncio.subprocess.PIPE, env=dict(os.environ),
    )  # fmt: skip
    peer = Peer(process)
    try:
        await peer.wait_for(lambda line: line.get("ready"), timeout=READY_TIMEOUT)
    except BaseException:
        await peer.stop()
        raise
    return peer
