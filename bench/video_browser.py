"""The video benchmark's browser part (#16): publisher stamp to a picture decoded in Chromium, H.264 (a WebCodecs
``VideoFrame`` output) beside JPEG (``createImageBitmap`` resolved), same relay, same publisher, same page.

The page is the real client (desktop, Robot POV, live) in Debian's Chromium. It records each decoded picture's
header stamp beside ``performance.now()`` (xr_client/src/picture_times.js, read through
``window.__xrRelay.pictureTimes``). The publisher stamps with ``time.monotonic()``, which this process shares; the
page's clock is mapped onto it by the quickest of several ``performance.now()`` round trips (the mapping's error is
at most half that round trip, recorded). The page draws at ``?maxfps=2`` in low quality: WebGL is SwiftShader here,
and its frames (100-300 ms of the main thread, where WebCodecs' output callbacks also run) would otherwise be most of
what is measured; a headset's GPU draws a frame in a few milliseconds. Its draws still delay some callbacks: the
p99 says how much.
"""

from __future__ import annotations

import asyncio
import json
import time
from collections.abc import Callable
from typing import Any

from .bench_client_frame import CHROMIUM, CHROMIUM_ARGS, chromium_missing, press, wait_state
from .common import TOKEN, JsonDict, summary

#: The issue's targets (#16): publisher stamp to decoded in the browser, 720p30 on loopback.
TARGET_P50_MS = 40.0
TARGET_P99_MS = 80.0
VIEWPORT = {"width": 960, "height": 600}
#: performance.now() round trips to map the page's clock onto this process's (the quickest one counts).
CLOCK_SAMPLES = 15


async def page_offset(page: Any, clock: Callable[[], float] = time.monotonic) -> tuple[float, float]:
    """(seconds to add to the page's performance.now()/1000 to get ``clock()``, half the round trip in s)."""
    best: tuple[float, float] | None = None
    for _ in range(CLOCK_SAMPLES):
        t0 = clock()
        at: float = await page.evaluate("performance.now()")
        t1 = clock()
        if best is None or t1 - t0 < 2 * best[1]:
            best = ((t0 + t1) / 2 - at / 1000, (t1 - t0) / 2)
    assert best is not None
    return best


async def measure_codec(browser: Any, port: int, robot: str, codec: str, seconds: float, warmup: float) -> JsonDict:
    """One page streaming ``robot``'s camera live as ``codec`` (``h264``, or ``jpeg`` by ``?video=jpeg``)."""
    page = await browser.new_page(viewport=VIEWPORT)
    try:
        forced = "&video=jpeg" if codec == "jpeg" else ""
        await page.goto(f"http://127.0.0.1:{port}/?quality=low&maxfps=2{forced}#token={TOKEN}")
        await wait_state(page, f"s.connected && s.robots['{robot}'] !== undefined", 120)
        await press(page, f"robot:{robot}")
        await wait_state(page, f"s.menu.selected === '{robot}'", 30)
        await press(page, "mode:pov")
        await wait_state(page, "s.menu.mode === 'pov'", 30)
        for _ in range(5):  # the button acts once the POV's first snapshot is in: pressed until it does
            if await page.evaluate("window.__xrRelay.state.menu.live"):
                break
            await press(page, "camera:live")
            await asyncio.sleep(2.0)
        shown = "s.video.decoded >= 10" if codec == "h264" else "s.pov.decoded >= 10"
        try:
            await wait_state(page, f"s.menu.live && {shown}", 60)
        except Exception as exc:
            s = await page.evaluate("(() => { const s = window.__xrRelay.state; return {live: s.menu.live, "
                                    "pov: s.pov, video: s.video, connected: s.connected}; })()")  # fmt: skip
            raise TimeoutError(f"no pictures shown in 60 s: {json.dumps(s)}") from exc
        state: JsonDict = await page.evaluate("window.__xrRelay.state.video")
        if state["codec"] != codec:
            return {"codec": codec, "error": f"the page streams {state['codec']} (fallback: {state['fallback']})"}
        await asyncio.sleep(warmup)
        offset, error = await page_offset(page)
        start = time.monotonic()
        before: JsonDict = await page.evaluate("window.__xrRelay.state")
        await asyncio.sleep(seconds)
        after: JsonDict = await page.evaluate("window.__xrRelay.state")
        end = time.monotonic()
        offset2, error2 = await page_offset(page)
        # What the operator is shown at the end of the window (the robot card's and the POV's picture figure, the
        # median of its last 15 pictures: xr_client/src/latency.js), beside this measure of the same 15 pictures:
        # read in one look, so no picture arrives between the two.
        times: list[list[float]]
        robots: JsonDict
        times, robots = await page.evaluate(
            "[window.__xrRelay.pictureTimes(2000), window.__xrRelay.state.latency.robots]"
        )
        shown = robots[robot]["picture"]
        last = sorted(at / 1000 + offset2 - stamp for stamp, at in times[-15:])
        # The clocks' mapping at both ends: their drift over the window is part of the error.
        mapping = (offset + offset2) / 2
        latencies = [at / 1000 + mapping - stamp for stamp, at in times if start <= at / 1000 + mapping <= end]
        wall = end - start
        return {
            "codec": codec,
            "pictures_per_s": round(len(latencies) / wall, 2),
            "latency_ms": summary(latencies),
            "clock_error_ms": round(1000 * (max(error, error2) + abs(offset2 - offset) / 2), 3),
            "shown_ms": None if shown is None else round(shown, 2),
            "measured_last_ms": round(1000 * (last[(len(last) - 1) // 2] + last[len(last) // 2]) / 2, 2)
            if last
            else None,
            "decoded": after["video"]["decoded"] - before["video"]["decoded"] if codec == "h264" else None,
            "decoder_errors": after["video"]["errors"] - before["video"]["errors"],
            # What the page drew meanwhile (its draws hold the main thread, where decode callbacks run too).
            "page_renders_per_s": round((after["timing"]["renders"] - before["timing"]["renders"]) / wall, 2),
        }
    finally:
        await page.close()


async def browser_part(port: int, robot: str, *, seconds: float, warmup: float) -> JsonDict:
    """H.264 then JPEG, each in a fresh page of one Chromium, against the relay at ``port``."""
    reason = chromium_missing()
    if reason is not None:
        return {"skipped": reason}
    from playwright.async_api import async_playwright

    out: JsonDict = {"pages": []}
    async with async_playwright() as playwright:
        browser = await playwright.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
        try:
            for codec in ("h264", "jpeg"):
                try:
                    out["pages"].append(await measure_codec(browser, port, robot, codec, seconds, warmup))
                except Exception as exc:  # Playwright's timeouts and page errors: said in the results
                    out["pages"].append({"codec": codec, "error": f"{type(exc).__name__}: {exc}".split("\n")[0]})
        finally:
            await browser.close()
    return out
