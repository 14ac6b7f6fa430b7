"""The browser tests' side of a page of the operator station: Debian's Chromium as Playwright drives it, the relay
under test (a Station) and a page (a Client) with waits on the client's read-only state
(`window.__xrRelay.state`), screenshots as artefacts and frame timings. The fixtures that make them are in
tests/e2e/conftest.py."""

from __future__ import annotations

import dataclasses
import fcntl
import json
import math
import os
import shutil
import time
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any, Final, TypeVar, overload

import pytest_asyncio
from playwright.async_api import Dialog, Page
from playwright.async_api import Error as PlaywrightError

from tests.conftest import ROOT, RunningRelay
from tests.helpers import waiting

#: The least a browser test waits for anything (its own timeout when longer). Every wait here is for a condition, never
#: a measurement: on a 2-core machine loaded beside them (a fresh clone's run with other work going on, load 13),
#: SwiftShader drew 1-2 frames a second, a hand's ray took over 10 s to reach the wrist E-STOP it was aimed at, and a
#: goal's robot over 15 s to start moving. Waiting longer costs time only when a test is failing anyway.
PATIENCE = 30.0


async def wait_until(predicate: Callable[[], bool], timeout: float, what: str) -> None:
    """The browser tests' poll of the relay's state: tests.helpers.waiting's, given at least PATIENCE."""
    await waiting.wait_until(predicate, max(timeout, PATIENCE), what)


CHROMIUM = Path("/usr/bin/chromium")
#: The browser tests share one event loop per worker, that of the worker's one Chromium (Playwright's connection
#: belongs to the loop that started it; tests/e2e/conftest.py). A Chromium per test cost each test its launch and, in
#: SwiftShader, the compilation of every shader the page uses: a second page in the same browser took 0.15 s of the
#: GPU process's CPU to load where the first took 0.87 s, and the launch 0.6 s more (this 2-core machine, one page).
LOOP: Final = "session"
_Fixture = TypeVar("_Fixture", bound=Callable[..., Any])


@overload
def fixture(function: _Fixture) -> _Fixture: ...
@overload
def fixture(*, autouse: bool = False) -> Callable[[_Fixture], _Fixture]: ...
def fixture(function: Any = None, *, autouse: bool = False) -> Any:
    """The decorator of every async fixture of the browser tests (``@fixture`` or ``@fixture(autouse=True)``): it
    runs on their loop."""
    if function is None:
        return pytest_asyncio.fixture(loop_scope=LOOP, autouse=autouse)
    return pytest_asyncio.fixture(function, loop_scope=LOOP)


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
#: The emulated headset (IWER), paced at 12 XR frames a second (xr_client/src/emulator_pace.js). Unpaced, SwiftShader
#: draws back to back and a VR page takes a whole core from the browser beside it: 13 VR tests took 170 s paced, 210 s
#: unpaced, two at once. At 5 a second a goal was dropped as stale in 2 of 3 loaded runs (goal_at_backend now sends
#: one again, as an operator would). Every VR page has it, the voice tests' and the hundred robots' included.
HEADSET = "emulate=quest3&xrfps=12"
#: The page size of a VR test (IWER draws both eyes into it). In CI every one of its XR frames is drawn by SwiftShader
#: as fast as it can: a VR page alone drew 13.3 frames a second at 640x400 and 21.4 at 320x200 (the machine busy
#: either way), and two browsers share two cores: 13 VR tests took 276 s at 640x400 and 210 s at 320x200, two at
#: once. Rays, hovers and label sizes are the scene's, not the page's pixels. The pictures docs/ shows: 640x400.
VR_VIEW = (640, 400) if UPDATE_DOC_IMAGES else (320, 200)


@dataclasses.dataclass
class Station:
    """The relay under test and what the browser tests need to know about it."""

    running: RunningRelay
    camera: str | None  # the camera Robot POV will show, or None when the fleet has none
    synthetic: bool
    velocities: list[tuple[float, str, float, float]]  # (monotonic time, robot, linear, angular) at the backend
    goals: list[tuple[str, float, float, float | None]]  # (robot, x, y, yaw) as the backend received them
    refusals: list[tuple[str, str]]  # (code, message) of every error the relay sent a page

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


async def goal_at_backend(
    station: Station, send_again: Callable[[], Awaitable[object]], tries: int = 3, timeout: float = 20.0
) -> tuple[str, float, float, float | None]:
    """The first goal at the backend, once the page has sent it. A goal the relay dropped as ``stale`` is sent again
    with ``send_again``, as an operator would after reading the notice: the relay dates a frame read just after a
    stall of its loop to the stall's start (docs/protocol.md), and in these tests the relay shares its loop with the
    test's own Playwright and a loaded machine's stalls last 0.5-0.8 s. Any other refusal, or nothing, fails."""

    def stale() -> int:
        return sum(1 for code, text in station.refusals if code == "stale" and "/goal_pose" in text)

    handled = 0

    def answered() -> bool:
        return bool(station.goals) or stale() > handled

    for _ in range(tries):
        await wait_until(answered, timeout, "the goal at the backend")
        if station.goals:
            return station.goals[0]
        handled = stale()
        await send_again()
    raise AssertionError(f"the goal was dropped as stale {handled} times: {station.refusals[-3:]}")


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
            timeout=max(timeout, PATIENCE) * 1000,
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


def native_dialogs(page: Page) -> list[str]:
    """Every native dialog (alert, confirm, prompt) the page opens from now, dismissed at once and listed: the
    station has none (they block the page, and E-STOP's keys with it); a test asserts the list stays empty."""
    opened: list[str] = []

    async def refuse(dialog: Dialog) -> None:
        opened.append(f"{dialog.type}: {dialog.message}")
        await dialog.dismiss()

    page.on("dialog", refuse)
    return opened


async def covered(page: Page, selector: str) -> list[str]:
    """The elements matching the selector (by their data-button, else their text) whose centre is off the window or
    under something else: what an operator could not click where it is drawn. Empty when all are in reach."""
    result: list[str] = await page.evaluate(
        """(selector) => [...document.querySelectorAll(selector)].filter((e) => {
          const r = e.getBoundingClientRect(), x = r.left + r.width / 2, y = r.top + r.height / 2;
          const inside = x >= 0 && y >= 0 && x < innerWidth && y < innerHeight;
          return !inside || !e.contains(document.elementFromPoint(x, y));
        }).map((e) => e.dataset.button || e.textContent)""",
        selector,
    )
    return result


async def confirm_reset(page: Page, click: str = '#estop-banner button[data-button="estop:reset"]') -> str:
    """Press a Reset E-STOP (the banner's, or CLICK) and answer yes to the question it asks first (the page's own
    dialog); returns the question, which names whose E-STOP the reset lifts."""
    await page.click(click)
    await page.wait_for_selector("#confirm-dialog[open]")
    question = await page.inner_text("#confirm-dialog p")
    await page.click('#confirm-dialog button[value="yes"]')
    return question


def record_timing(key: str, value: dict[str, Any]) -> None:
    """Merge one measurement into test-artifacts/frame_timing.json (under a lock: tests run in parallel)."""
    ARTIFACTS.mkdir(exist_ok=True)
    path = ARTIFACTS / "frame_timing.json"
    with (ARTIFACTS / "frame_timing.lock").open("w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
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


async def choose(client: Client, robot: str, tool: str) -> None:
    """Select a robot and a tool in the desktop menu."""
    await client.page.click(f'#menu button[data-button="robot:{robot}"]')
    await client.page.click(f'#menu button[data-button="tool:{tool}"]')
    await client.wait("s.menu.selected === arg[0] && s.menu.tool === arg[1]", 10, [robot, tool])


async def measure_rate(station: Station, robot: str, seconds: float) -> float:
    """cmd_vel per second at the backend over a window (waiting on the clock is the measurement)."""
    t0 = time.monotonic()
    await wait_until(lambda: time.monotonic() - t0 >= seconds, seconds + 1, "the measuring window")
    stamps = [t for t, _, _ in station.velocities_of(robot, t0)]
    return len(stamps) / seconds


async def snapshot_until_uploaded(
    client: Client, press: Callable[[], Awaitable[object]], timeout: float = 60.0
) -> None:
    """Ask for snapshots until one reaches the texture. A simulated camera may not have rendered its first
    image yet (`no_camera`, "try again shortly"): ask again after each answer."""
    deadline = time.monotonic() + timeout
    start = (await client.state())["pov"]["uploads"]
    while True:
        s = await client.state()
        requested = s["pov"]["snapshots"]["requested"]
        await press()
        answered = await client.wait(
            "(s.pov.snapshots.acked + s.pov.snapshots.failed >= arg) && s.pov.snapshots", 15, requested + 1
        )
        if answered["acked"] > 0:
            await client.wait("s.pov.uploads > arg", 15, start)
            return
        if time.monotonic() > deadline:
            raise AssertionError(f"no snapshot within {timeout} s: {answered}")


async def open_wipe(client: Client) -> None:
    """The open changed finding's before/after box, both images loaded and the change outlined over the after."""
    page = client.page
    loaded = "() => [...document.querySelectorAll('#findings .wipe img')].every((i) => i.naturalWidth > 0)"
    await page.wait_for_selector("#findings .wipe img.before")
    await page.wait_for_function(loaded, timeout=30_000)
    await page.wait_for_selector("#findings .wipe .after polygon")


async def wiped(client: Client, position: int) -> bytes:
    """Move the before/after slider to ``position`` (0-100) and take the box's picture once the clip is painted."""
    await client.page.locator("#findings input[data-wipe]").fill(str(position))
    await client.wait(f"s.inspection.card.wipe === {position}")
    await client.page.wait_for_timeout(100)  # the clip painted
    for _ in range(2):
        # The panel is redrawn when what it lists changes (a round's progress): the box is drawn anew, at the same
        # position, and its picture is taken again.
        try:
            return await client.page.locator("#findings .capture.wipe").screenshot()
        except PlaywrightError as exc:
            if "not attached" not in str(exc):
                raise
        await client.wait(f"s.inspection.card.wipe === {position}")
        await client.page.wait_for_timeout(100)
    return await client.page.locator("#findings .capture.wipe").screenshot()
