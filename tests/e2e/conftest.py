"""Fixtures for the browser tests: the relay in-process on port 0, Debian's Chromium driven by Playwright's
async API (WebGL on SwiftShader), the headset emulated by IWER through the client's `?emulate=quest3`,
and helpers that wait on the client's read-only state (`window.__xrRelay.state`).

When the fleet of robots.yaml has no camera yet, the relay is given a synthetic one per robot (a
fisheye-like test pattern served as JPEG through the real snapshot and stream paths), so that Robot POV
is tested end to end either way.
"""

from __future__ import annotations

import asyncio
import dataclasses
import io
import json
import math
import os
import shutil
import time
from collections.abc import AsyncIterator, Awaitable, Callable
from pathlib import Path
from typing import Any

import pytest
from playwright.async_api import Browser, Page, async_playwright

from relay.config import FleetConfig, load_config
from relay.events import FrameEvent
from tests.conftest import ROOT, RunningRelay, start_relay

CHROMIUM = Path("/usr/bin/chromium")
ARTIFACTS = ROOT / "test-artifacts"
DOC_IMAGES = ROOT / "docs" / "img"
#: Set to copy the screenshots docs/client.md shows into docs/img/ (`XR_RELAY_DOC_IMAGES=1 make test`).
UPDATE_DOC_IMAGES = os.environ.get("XR_RELAY_DOC_IMAGES") == "1"
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-quic",
    "--no-first-run",
    "--enable-unsafe-swiftshader",
    "--use-angle=swiftshader",
    "--disable-background-timer-throttling",
    "--disable-renderer-backgrounding",
]
#: The client's options for a software-rendered browser (xr_client/src/main.js): no multisampling, a lower
#: resolution, at most a few drawn frames a second. With --disable-gpu, Chromium reads every WebGL frame
#: back for its software compositor and holds the page meanwhile; drawing less leaves the page's own
#: timers (input, pings) and IWER's input frames their time. Teleop's 20 Hz runs in the socket worker, whatever
#: the frames do (tests/e2e/test_teleop_rate.py).
SOFTWARE_GL = "quality=low&maxfps=2"
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


@dataclasses.dataclass
class Station:
    """The relay under test and what the browser tests need to know about it."""

    running: RunningRelay
    camera: str | None  # the camera Robot POV will show, or None when the fleet has none
    synthetic: bool
    velocities: list[tuple[float, str, float, float]]  # (monotonic time, robot, linear, angular) at the backend
    goals: list[tuple[str, float, float, float | None]]  # (robot, x, y, yaw) as the backend received them

    @property
    def url(self) -> str:
        return self.running.url

    def status(self, robot: str) -> dict[str, Any]:
        """The robot's status as the relay would send it now (mode, goal, controller)."""
        return dict(self.running.relay.fleet.status(robot, time.monotonic()))

    def pose(self, robot: str) -> tuple[float, float]:
        pose = self.running.relay.fleet.snapshot(time.monotonic())[robot]["pose"]
        assert pose is not None, f"{robot} has no pose"
        return pose["x"], pose["y"]

    def velocities_of(self, robot: str, since: float = 0.0) -> list[tuple[float, float, float]]:
        return [(t, lin, ang) for t, r, lin, ang in self.velocities if r == robot and t >= since]


@pytest.fixture
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
    try:
        yield Station(running, first.cameras[0].name if first else None, synthetic is not None, velocities, goals)
    finally:
        if cameras is not None:
            cameras.close()
        await running.runner.cleanup()


@pytest.fixture
async def browser(tmp_path: Path) -> AsyncIterator[Browser]:
    if not await asyncio.to_thread(CHROMIUM.exists):
        pytest.skip(f"the browser tests need Debian's Chromium at {CHROMIUM} (make test installs it)")
    # WebGL on SwiftShader keeps every core busy; niced, the browser leaves the in-process relay (whose
    # event loop the blocking check watches) the CPU it needs on a loaded 2-core machine.
    launcher = tmp_path / "chromium-niced"
    await asyncio.to_thread(launcher.write_text, f'#!/bin/sh\nexec nice -n 10 {CHROMIUM} "$@"\n')
    await asyncio.to_thread(launcher.chmod, 0o755)
    async with async_playwright() as playwright:
        chromium = await playwright.chromium.launch(executable_path=str(launcher), args=CHROMIUM_ARGS)
        try:
            yield chromium
        finally:
            await chromium.close()


class Client:
    """One page of the operator station, with waits on its state and screenshots as artefacts."""

    def __init__(self, page: Page, name: str) -> None:
        self.page = page
        self.name = name
        self.errors: list[str] = []
        page.on("pageerror", lambda error: self.errors.append(str(error)))
        page.on(
            "console",
            lambda message: (
                self.errors.append(message.text) if message.type == "error" and "favicon" not in message.text else None
            ),
        )

    async def state(self) -> dict[str, Any]:
        result: dict[str, Any] = await self.page.evaluate("window.__xrRelay.state")
        return result

    async def wait(self, condition: str, timeout: float = 20.0, arg: Any = None) -> Any:
        """Wait until a JS expression over the state `s` (and `arg`) is truthy; returns its value."""
        handle = await self.page.wait_for_function(
            f"(arg) => {{ const s = window.__xrRelay && window.__xrRelay.state; return s && ({condition}); }}",
            arg=arg,
            timeout=timeout * 1000,
            polling=50,
        )
        return await handle.json_value()

    async def frames(self, n: int = 3, timeout: float = 20.0) -> None:
        """Wait for n more rendered frames (IWER applies input on the next XR frame)."""
        start = (await self.state())["timing"]["frames"]
        await self.wait("s.timing.frames >= arg", timeout, start + n)

    async def drawn(self, n: int, timeout: float = 60.0) -> dict[str, Any]:
        """Wait for n more drawn frames; returns the timing snapshot from before (for window_stats)."""
        before: dict[str, Any] = (await self.state())["timing"]
        await self.wait("s.timing.renders >= arg", timeout, before["renders"] + n)
        return before

    async def shot(self, step: str, doc_name: str | None = None) -> Path:
        ARTIFACTS.mkdir(exist_ok=True)
        path = ARTIFACTS / f"{self.name}-{step}.png"
        await self.page.screenshot(path=str(path))
        if doc_name and UPDATE_DOC_IMAGES:
            DOC_IMAGES.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(path, DOC_IMAGES / doc_name)
        return path


OpenClient = Callable[..., Awaitable[Client]]


@pytest.fixture
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


async def wait_until(predicate: Callable[[], bool], timeout: float, what: str) -> None:
    """Poll a Python-side condition (the relay's state) without blocking the loop."""
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout} s waiting for {what}")
        await asyncio.sleep(0.05)


def record_timing(key: str, value: dict[str, Any]) -> None:
    """Merge one measurement into test-artifacts/frame_timing.json."""
    ARTIFACTS.mkdir(exist_ok=True)
    path = ARTIFACTS / "frame_timing.json"
    data = json.loads(path.read_text()) if path.exists() else {}
    data[key] = value
    path.write_text(json.dumps(data, indent=2) + "\n")


def window_stats(before: dict[str, Any], after: dict[str, Any]) -> dict[str, Any]:
    """JS ms per drawn frame between two `state.timing` snapshots (from the client's recent samples)."""
    drawn = after["renders"] - before["renders"]
    samples = sorted(after["recent"][-drawn:]) if drawn > 0 else []
    if not samples:
        return {"frames": 0}
    return {
        "frames": len(samples),
        "p50": samples[len(samples) // 2],
        "p95": samples[min(len(samples) - 1, int(0.95 * len(samples)))],
        "max": samples[-1],
    }


def distance(a: tuple[float, float], b: tuple[float, float]) -> float:
    return math.hypot(a[0] - b[0], a[1] - b[1])
