"""Shared fixtures: real relays on loopback port 0, real WebSocket clients, and a loop-blocking check."""

from __future__ import annotations

import asyncio
import itertools
import logging
import os
import random
import re
import sys
import threading
import time
from collections.abc import AsyncIterator, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import hypothesis  # noqa: F401 - imported up front: its plugin's lazy import at session end trips CPython 3.11.7
import pytest
from aiohttp import web

import relay.backends.sim  # noqa: F401 - imported once here, as the relay does at start-up: trimesh and

# Embree take a second to import, which would otherwise count as the first test's loop blocking.
from relay.config import FleetConfig, load_config
from relay.core import Relay
from relay.options import Options
from relay.server import RELAY_KEY, create_app, open_runner

ROOT = Path(__file__).resolve().parent.parent
SHARED_DATA = ROOT.parent / "shared" / "data"

#: A callback holding the loop longer than this fails the test: it would freeze every client's stream.
#: Half a second, not less: on a loaded 2-core machine, forking a subprocess or a burst of garbage
#: collection alone can hold a step for a few hundred milliseconds without any blocking call.
BLOCKING_THRESHOLD = 0.5

_SLOW = re.compile(r"^Executing .* took (\d+\.\d+) seconds$", re.S)


class Canary(threading.Thread):
    """Wakes every 10 ms and notes how late it woke: the measure of the whole process being starved.

    A callback that blocks the loop with a sleep or blocking I/O releases the GIL, and one that computes in
    Python gives it up every 5 ms: either way the canary keeps waking on time. When the canary is late too,
    the machine (or another thread holding the GIL in C code) starved the whole process, and a long callback
    in that window says nothing about the relay.
    """

    def __init__(self) -> None:
        super().__init__(name="loop-block-canary", daemon=True)
        self.late: list[tuple[float, float]] = []  # (wake time, lateness) for wake-ups over 50 ms late
        self.running = True

    def run(self) -> None:
        while self.running:
            before = time.monotonic()
            time.sleep(0.01)
            lateness = time.monotonic() - before - 0.01
            if lateness > 0.05:
                self.late.append((time.monotonic(), lateness))

    def starved(self, start: float, end: float) -> float:
        """The longest lateness the canary saw between ``start`` and ``end`` (monotonic seconds)."""
        return max((late for at, late in self.late if start <= at <= end + 0.05), default=0.0)


class SlowCallbackCollector(logging.Handler):
    """Collects asyncio debug-mode reports of callbacks that held the event loop."""

    def __init__(self, threshold: float) -> None:
        super().__init__(logging.WARNING)
        self.threshold = threshold
        self.reports: list[str] = []
        self.slow: list[tuple[float, float, str]] = []  # (end, duration, report)

    def emit(self, record: logging.LogRecord) -> None:
        text = record.getMessage()
        match = _SLOW.match(text)
        # Playwright's driver pipe decodes whole screenshots in one step: the browser tests' machinery,
        # not the relay, and no relay runs that code.
        if match and "playwright/_impl" not in text and float(match.group(1)) >= self.threshold:
            self.reports.append(text)
            self.slow.append((time.monotonic(), float(match.group(1)), text))

    def blocking(self, canary: Canary) -> list[str]:
        """Reports not explained by the process being starved while they ran."""
        return [text for end, took, text in self.slow if canary.starved(end - took, end) < took / 2]


@pytest.fixture
def loop_block_collector() -> Iterator[SlowCallbackCollector]:
    collector = SlowCallbackCollector(BLOCKING_THRESHOLD)
    logger = logging.getLogger("asyncio")
    logger.addHandler(collector)
    try:
        yield collector
    finally:
        logger.removeHandler(collector)


@pytest.fixture(autouse=True)
async def _fail_on_blocking(
    request: pytest.FixtureRequest, loop_block_collector: SlowCallbackCollector
) -> AsyncIterator[None]:
    """Every async test runs with asyncio debug mode; a callback that blocks the loop fails the test."""
    loop = asyncio.get_running_loop()
    loop.set_debug(True)
    loop.slow_callback_duration = BLOCKING_THRESHOLD
    canary = Canary()
    canary.start()
    yield
    canary.running = False
    blocking = loop_block_collector.blocking(canary)
    if blocking and "allow_blocking" not in request.keywords:
        pytest.fail("the event loop was blocked:\n" + "\n".join(blocking[:5]))


@pytest.fixture
def fleet_config() -> FleetConfig:
    return load_config(ROOT / "robots.yaml")


@dataclass
class RunningRelay:
    url: str
    ws_url: str
    relay: Relay
    runner: web.AppRunner


async def start_relay(config: FleetConfig, backend: str = "sim", options: Options | None = None) -> RunningRelay:
    app = create_app(config, options or Options(backend=backend))
    runner = await open_runner(app)
    site = web.TCPSite(runner, "127.0.0.1", 0)
    await site.start()
    host, port = runner.addresses[0][:2]
    return RunningRelay(f"http://{host}:{port}", f"ws://{host}:{port}/ws", app[RELAY_KEY], runner)


@pytest.fixture
async def relay_server(fleet_config: FleetConfig) -> AsyncIterator[RunningRelay]:
    running = await start_relay(fleet_config)
    try:
        yield running
    finally:
        await running.runner.cleanup()


_DOMAINS = itertools.count(random.randint(20, 120))


@pytest.fixture
def ros_domain(monkeypatch: pytest.MonkeyPatch) -> int:
    """A ROS_DOMAIN_ID of this test's own, discovery on this machine only: runs never see each other."""
    domain = next(_DOMAINS)
    monkeypatch.setenv("ROS_DOMAIN_ID", str(domain))
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    return domain


async def relay_process(
    *args: str, stderr: int = asyncio.subprocess.DEVNULL, port: int = 0, **options: Any
) -> tuple[asyncio.subprocess.Process, str]:
    """``python -m relay ARGS --port PORT`` (default 0: any free one) in a process of its own (this environment, so
    this test's ROS domain); returns it and the base URL it printed (``http://127.0.0.1:P``). ``options`` go to
    create_subprocess_exec."""
    process = await asyncio.create_subprocess_exec(
        sys.executable, "-m", "relay", *args, "--port", str(port), cwd=ROOT, stdout=asyncio.subprocess.PIPE,
        stderr=stderr, env=dict(os.environ), **options,
    )  # fmt: skip
    assert process.stdout is not None
    line = (await asyncio.wait_for(process.stdout.readline(), 60)).decode()
    if "open " not in line:
        process.kill()
        await process.wait()
        raise AssertionError(f"the relay did not start: it printed {line!r}")
    return process, line.split("open ")[1].split("/#")[0]
