"""Fixtures for the browser tests: the relay in-process on port 0, Debian's Chromium driven by Playwright's
async API (WebGL on SwiftShader; one Chromium per worker, on the worker's one event loop, each test's pages and
contexts closed at its end), the headset emulated by IWER through the client's `?emulate=quest3`. The
helpers that wait on the client's read-only state (`window.__xrRelay.state`) are in tests/helpers/browser.py.

When the fleet of robots.yaml has no camera yet, the relay is given a synthetic one per robot (a
fisheye-like test pattern served as JPEG through the real snapshot and stream paths), so that Robot POV
is tested end to end either way.
"""

from __future__ import annotations

import asyncio
import dataclasses
import inspect
import io
import os
import time
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import pytest
import pytest_asyncio
from playwright.async_api import Browser, BrowserContext, Page, Playwright, async_playwright

from relay.config import FleetConfig, load_config
from relay.fleet.events import FrameEvent
from tests.conftest import ROOT, RunningRelay, SlowCallbackCollector, blocking_checks, start_relay
from tests.helpers.browser import CHROMIUM, CHROMIUM_ARGS, LOOP, Client, OpenClient, Station, fixture

SYNTHETIC_CAMERA = "front"
SYNTHETIC_SIZE = 512
SYNTHETIC_FPS = 15.0


def _test_pattern(robot: str, seq: int) -> bytes:
    """An equidistant-fisheye-like test pattern: rings every 30 degrees, the robot's name in the middle."""
    from PIL import Image, ImageDraw

    size = SYNTHETIC_SIZE
    image = Image.new("RGB", (size, size), (0, 0, 0))
    draw = ImageDraw.Draw(image)
    c = size / 2
    colours = [(230, 25, 75), (60, 180, 75), (67, 99, 216)]
    for k, radius in enumerate((size / 2, size / 3, size / 6)):
        draw.ellipse((c - radius, c - radius, c + radius, c + radius), fill=colours[(k + seq) % 3])
    draw.line((c, 0, c, size), fill=(255, 255, 255), width=3)
    draw.line((0, c, size, c), fill=(255, 255, 255), width=3)
    draw.text((c - 30, c - 20), f"{robot}\n#{seq}", fill=(255, 255, 255))
    out = io.BytesIO()
    image.save(out, "JPEG", quality=80)
    return out.getvalue()


def _with_synthetic_cameras(config: FleetConfig) -> FleetConfig | None:
    """The fleet with a 'front' camera on every robot, or None if this config's shape is not understood."""
    try:
        from relay.config import Camera, Lens

        camera = Camera(
            name=SYNTHETIC_CAMERA,
            topic="camera/image_raw",
            compressed=False,
            lens=Lens("equidistant", 180.0),
            width=SYNTHETIC_SIZE,
            height=SYNTHETIC_SIZE,
            rate=SYNTHETIC_FPS,
        )
        robots = tuple(dataclasses.replace(r, cameras=(camera,)) for r in config.robots)
        return dataclasses.replace(config, robots=robots)
    except (TypeError, ValueError, ImportError):
        return None


class SyntheticCameras:
    """Serves the test pattern through the relay's own snapshot and stream paths (FrameEvents)."""

    def __init__(self, running: RunningRelay, frames: dict[str, list[bytes]]) -> None:
        self.relay = running.relay
        self.frames = frames
        self.tasks: dict[str, asyncio.Task[None]] = {}
        self.seq = 0

    def _event(self, robot: str) -> FrameEvent:
        self.seq += 1
        jpeg = self.frames[robot][self.seq % len(self.frames[robot])]
        return FrameEvent(
            robot=robot,
            camera=SYNTHETIC_CAMERA,
            stamp=time.time(),
            width=SYNTHETIC_SIZE,
            height=SYNTHETIC_SIZE,
            jpeg=jpeg,
        )

    async def snapshot(self, robot: str, camera: str) -> FrameEvent | None:
        return self._event(robot)

    def set_stream(self, robot: str, camera: str, fps: float) -> None:
        task = self.tasks.pop(robot, None)
        if task is not None:
            task.cancel()
        if fps > 0:
            self.tasks[robot] = asyncio.get_running_loop().create_task(self._stream(robot, fps))

    async def _stream(self, robot: str, fps: float) -> None:
        while True:
            self.relay.on_event(self._event(robot))
            await asyncio.sleep(1.0 / fps)

    def close(self) -> None:
        for task in self.tasks.values():
            task.cancel()


#: The heavy VR scenarios (marked ``heavy``) run when this is set (`make test-heavy`). Each draws a headset's frames on
#: SwiftShader for 3-7 minutes at full CPU: in `make test` beside the other browser tests, on two cores, they made
#: their neighbours miss their bounds (a frozen page's stop, a card's screenshot) and missed their own (a fresh
#: clone's run, load average 15).
HEAVY = os.environ.get("XR_RELAY_HEAVY") == "1"


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    here = Path(__file__).parent
    for item in items:
        if here not in Path(str(item.path)).parents:
            continue  # this hook sees the whole run's items
        if inspect.iscoroutinefunction(getattr(item, "obj", None)):
            # Before any marker pytest-asyncio gave it: the closest one sets the loop.
            item.add_marker(pytest.mark.asyncio(loop_scope=LOOP), append=False)
        if item.get_closest_marker("heavy") is not None and not HEAVY:
            item.add_marker(
                pytest.mark.skip(reason="a heavy VR scenario (minutes of SwiftShader): XR_RELAY_HEAVY=1 runs it")
            )


@fixture(autouse=True)
async def _fail_on_blocking(
    request: pytest.FixtureRequest, loop_block_collector: SlowCallbackCollector, monkeypatch: pytest.MonkeyPatch
) -> AsyncIterator[None]:
    """The blocking checks of every test (tests/conftest.py), on the browser tests' shared loop; and what a test
    left running on it is cancelled at its end, as closing a loop of its own would have."""
    before = asyncio.all_tasks()
    async with blocking_checks(request, loop_block_collector, monkeypatch):
        yield
    left = asyncio.all_tasks() - before - {asyncio.current_task()}
    for task in left:
        task.cancel()
    await asyncio.gather(*left, return_exceptions=True)


@fixture
async def station() -> AsyncIterator[Station]:
    # Reading robots.yaml and the facility's occupancy grid takes a while: off the event loop.
    config = await asyncio.to_thread(load_config, ROOT / "robots.yaml")
    synthetic = None
    if not any(r.cameras for r in config.robots):
        synthetic = _with_synthetic_cameras(config)
    running = await start_relay(synthetic or config)
    cameras: SyntheticCameras | None = None
    if synthetic is not None:
        patterns = await asyncio.to_thread(
            lambda: {r.name: [_test_pattern(r.name, k) for k in range(3)] for r in config.robots}
        )
        cameras = SyntheticCameras(running, patterns)
        backend: Any = running.relay.backend
        backend.snapshot = cameras.snapshot
        backend.set_stream = cameras.set_stream
    fleet = synthetic or config
    first = next((r for r in fleet.robots if r.cameras), None)
    velocities: list[tuple[float, str, float, float]] = []
    backend = running.relay.backend
    original = backend.send_velocity

    async def spy(robot: str, linear: float, angular: float, *, stamp: float | None = None) -> None:
        velocities.append((time.monotonic(), robot, linear, angular))
        await original(robot, linear, angular, stamp=stamp)

    backend.send_velocity = spy
    goals: list[tuple[str, float, float, float | None]] = []
    original_goal = backend.send_goal

    async def goal_spy(robot: str, x: float, y: float, yaw: float | None, **options: Any) -> None:
        goals.append((robot, x, y, yaw))
        await original_goal(robot, x, y, yaw, **options)

    backend.send_goal = goal_spy
    refusals: list[tuple[str, str]] = []
    outbox = running.relay.outbox
    original_error = outbox.error

    def error_spy(client: Any, request_id: Any, code: str, message: str) -> None:
        refusals.append((code, message))
        original_error(client, request_id, code, message)

    outbox.error = error_spy  # type: ignore[method-assign]
    try:
        yield Station(
            running, first.cameras[0].name if first else None, synthetic is not None, velocities, goals, refusals
        )
    finally:
        if cameras is not None:
            cameras.close()
        await running.runner.cleanup()


class WorkerChromium:
    """The worker's one Chromium, launched again when it went away (crashed under an earlier test)."""

    def __init__(self, playwright: Playwright, executable: Path) -> None:
        self.playwright = playwright
        self.executable = executable
        self.chromium: Browser | None = None

    async def current(self) -> Browser:
        if self.chromium is None or not self.chromium.is_connected():
            self.chromium = await self.playwright.chromium.launch(
                executable_path=str(self.executable), args=CHROMIUM_ARGS
            )
        return self.chromium

    async def close(self) -> None:
        if self.chromium is not None and self.chromium.is_connected():
            await self.chromium.close()


@pytest_asyncio.fixture(scope="session", loop_scope=LOOP)
async def _chromium(tmp_path_factory: pytest.TempPathFactory) -> AsyncIterator[WorkerChromium | None]:
    if not await asyncio.to_thread(CHROMIUM.exists):
        yield None
        return
    # WebGL on SwiftShader keeps every core busy; niced, the browser leaves the in-process relay (whose
    # event loop the blocking check watches) the CPU it needs on a loaded 2-core machine.
    launcher = tmp_path_factory.mktemp("chromium") / "chromium-niced"
    await asyncio.to_thread(launcher.write_text, f'#!/bin/sh\nexec nice -n 10 {CHROMIUM} "$@"\n')
    await asyncio.to_thread(launcher.chmod, 0o755)
    async with async_playwright() as playwright:
        worker = WorkerChromium(playwright, launcher)
        try:
            yield worker
        finally:
            await worker.close()


@fixture
async def browser(_chromium: WorkerChromium | None) -> AsyncIterator[Browser]:
    """The worker's Chromium for one test: what the test opened in it (pages, contexts) is closed at its end."""
    if _chromium is None:
        pytest.skip(f"the browser tests need Debian's Chromium at {CHROMIUM} (make test installs it)")
    chromium = await _chromium.current()
    before: set[BrowserContext] = set(chromium.contexts)
    try:
        yield chromium
    finally:
        for context in set(chromium.contexts) - before:
            await context.close()


@fixture
async def open_client(browser: Browser) -> AsyncIterator[OpenClient]:
    pages: list[Page] = []

    async def open_(
        url: str, name: str, width: int = 1280, height: int = 760, *, operator: str | None = "Tess"
    ) -> Client:
        """A page of the station; ``operator`` is the name it goes by (``?name=``), None: the page asks for one."""
        page = await browser.new_page(viewport={"width": width, "height": height})
        pages.append(page)
        client = Client(page, name)
        if operator is not None and "name=" not in url:
            base, _, fragment = url.partition("#")
            url = f"{base}{'&' if '?' in base else '?'}name={operator}" + (f"#{fragment}" if fragment else "")
        await page.goto(url)
        await client.wait("s.connected && Object.keys(s.robots).length > 0 && s.twin.state !== 'loading'", 30)
        return client

    yield open_
    for page in pages:
        await page.close()
