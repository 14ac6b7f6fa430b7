"""Shared fixtures: real relays on loopback port 0, real WebSocket clients, and a loop-blocking check."""

from __future__ import annotations

import asyncio
import logging
import re
from collections.abc import AsyncIterator, Iterator
from dataclasses import dataclass
from pathlib import Path

import hypothesis  # noqa: F401 - imported up front: its plugin's lazy import at session end trips CPython 3.11.7
import pytest
from aiohttp import web

import relay.backends.sim  # noqa: F401 - imported once here, as the relay does at start-up: trimesh and

# Embree take a second to import, which would otherwise count as the first test's loop blocking.
from relay.config import FleetConfig, load_config
from relay.core import Relay
from relay.options import Options
from relay.server import RELAY_KEY, create_app

ROOT = Path(__file__).resolve().parent.parent
SHARED_DATA = ROOT.parent / "shared" / "data"

#: A callback holding the loop longer than this fails the test: it would freeze every client's stream.
BLOCKING_THRESHOLD = 0.25

_SLOW = re.compile(r"^Executing .* took (\d+\.\d+) seconds$", re.S)


class SlowCallbackCollector(logging.Handler):
    """Collects asyncio debug-mode reports of callbacks that held the event loop."""

    def __init__(self, threshold: float) -> None:
        super().__init__(logging.WARNING)
        self.threshold = threshold
        self.reports: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        text = record.getMessage()
        match = _SLOW.match(text)
        if match and float(match.group(1)) >= self.threshold:
            self.reports.append(text)


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
    yield
    if loop_block_collector.reports and "allow_blocking" not in request.keywords:
        pytest.fail("the event loop was blocked:\n" + "\n".join(loop_block_collector.reports[:5]))


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
    runner = web.AppRunner(app, shutdown_timeout=1.0)
    await runner.setup()
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
