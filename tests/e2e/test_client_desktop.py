"""The demo scenario on the desktop fallback, with mouse and keyboard: click a robot to select it, the HTML
menu for Goal, press on the floor and drag for the heading, WASD to drive, Robot POV in its panel with a
snapshot and a live stream. Screenshots go to test-artifacts/; JS time per frame to frame_timing.json."""

from __future__ import annotations

import asyncio
import math
import time

from playwright.async_api import Browser

from relay.cli.options import Options
from relay.config import load_config
from tests.conftest import ROOT, start_relay
from tests.helpers.browser import (
    SOFTWARE_GL,
    Client,
    OpenClient,
    Station,
    confirm_reset,
    distance,
    goal_at_backend,
    measure_rate,
    record_timing,
    snapshot_until_uploaded,
    wait_until,
)

GOAL = (10.0, 6.5)


async def page_point(client: Client, x: float, y: float) -> tuple[float, float]:
    px, py = await client.page.evaluate("([x, y]) => window.__xrRelay.mapToPage(x, y, 0)", [x, y])
    return px, py


async def name_target(client: Client, name: str) -> None:
    """Answer the page's target-name dialog (never a native prompt): type the name, Enter."""
    await client.page.wait_for_selector("#target-dialog[open]")
    await client.page.fill("#target-dialog input", name)
    await client.page.press("#target-dialog input", "Enter")
    await client.page.wait_for_selector("#target-dialog", state="hidden")


async def test_desktop_demo_scenario(station: Station, open_client: OpenClient) -> None:
    client = await open_client(f"{station.url}/?{SOFTWARE_GL}", "desktop", 1280, 760)
    page = client.page
    await client.drawn(2)  # frames run at every tick; with ?maxfps=2 a drawn one may lag them
    await client.shot("01-overview", "desktop-overview.png")

    # Click robot2 in the twin to select it.
    robot2 = station.pose("robot2")
    px, py = await page_point(client, robot2[0], robot2[1])
    await page.mouse.click(px, py - 4)
    await client.wait("s.menu.selected === 'robot2'")
    await page.click('#menu button[data-button="tool:goal"]')
    await client.wait("s.menu.tool === 'goal'")

    # Press on the floor for the position, drag east for the heading, release to send.
    x, y = GOAL
    gx, gy = await page_point(client, x, y)
    ex, ey = await page_point(client, x + 1.5, y)
    await page.mouse.move(gx, gy)
    await page.mouse.down()
    await client.wait("s.goal.pointer === 'placing'")
    await page.mouse.move(ex, ey, steps=4)
    await client.wait("s.goal.marker && s.goal.marker.yaw !== null")
    await client.shot("02-goal-drag", "desktop-goal.png")
    await page.mouse.up()
    await client.wait("s.goal.sent === 1")

    async def drag() -> None:
        await page.mouse.move(gx, gy)
        await page.mouse.down()
        await page.mouse.move(ex, ey, steps=4)
        await page.mouse.up()

    robot, sx, sy, syaw = await goal_at_backend(station, drag)
    assert robot == "robot2"
    assert distance((sx, sy), GOAL) < 0.3, (sx, sy)
    assert syaw is not None and abs(syaw) < 0.3
    await wait_until(lambda: station.status("robot2")["mode"] == "navigating", 10, "robot2 navigating")
    status = station.status("robot2")
    assert status["goal"] is not None
    assert distance((status["goal"]["x"], status["goal"]["y"]), (sx, sy)) < 1e-3
    start = station.pose("robot2")
    await wait_until(lambda: distance(station.pose("robot2"), start) > 0.3, 15, "robot2 moving")
    await client.shot("03-navigating")

    # Cancel goal: enabled while the robot follows one; the relay stops it there.
    await page.click('#menu button[data-button="goal:cancel"]:not([disabled])')
    await wait_until(lambda: station.status("robot2")["goal"] is None, 10, "the goal cancelled")
    await client.wait("s.menu.buttons.find((b) => b.id === 'goal:cancel').enabled === false")

    # WASD drives the selected robot through the same 20 Hz loop; releasing the key sends a zero.
    await page.click('#menu button[data-button="tool:teleop"]')
    await client.wait("s.menu.tool === 'teleop'")
    await page.locator("#viewport canvas").focus()
    pushed = time.monotonic()
    await page.keyboard.down("KeyW")
    await wait_until(
        lambda: any(lin > 0.5 for _, lin, _ in station.velocities_of("robot2", pushed)), 10, "cmd_vel forward"
    )
    me = (await client.state())["clientId"]
    await wait_until(
        lambda: station.status("robot2")["mode"] == "teleop" and station.status("robot2")["controller"] == me,
        5,
        "robot2 in teleop by this client",
    )
    rate = await measure_rate(station, "robot2", 2.0)
    record_timing("desktop_teleop_cmd_vel_per_s", {"rate": rate})
    assert 2 <= rate <= 24, f"{rate:.1f} cmd_vel per second; the client sends at 20 Hz"
    released = time.monotonic()
    await page.keyboard.up("KeyW")
    await wait_until(
        lambda: any(lin == 0 and ang == 0 for _, lin, ang in station.velocities_of("robot2", released)),
        5,
        "the zero on release",
    )
    # Turning off Teleop while nothing is pressed sends nothing more (a zero would cancel a goal).
    zeros = (await client.state())["commands"]["zeros"]
    await page.click('#menu button[data-button="tool:teleop"]')
    await client.wait("s.menu.tool === 'none'")
    assert (await client.state())["commands"]["zeros"] == zeros

    # E-STOP latches: the panel says so, Teleop is off for the stopped robot, and Reset E-STOP releases it.
    await page.click('#menu button[data-button="estop"]')
    await wait_until(lambda: station.status("robot2")["estopped"] is True, 5, "robot2 latched")
    await client.wait("s.menu.buttons.some((b) => b.id === 'estop:reset' && b.enabled)")
    await client.wait("s.menu.buttons.find((b) => b.id === 'tool:teleop').enabled === false")
    await client.drawn(2)
    await client.shot("03b-estop-latched")
    await confirm_reset(page, '#menu button[data-button="estop:reset"]')
    await wait_until(lambda: station.status("robot2")["estopped"] is False, 5, "robot2 released")
    await client.wait("!s.menu.buttons.some((b) => b.id === 'estop:reset')")
    await client.wait("s.menu.buttons.find((b) => b.id === 'tool:teleop').enabled === true")

    # Robot POV: the hemisphere in its panel, a snapshot, then live.
    if station.camera is None:
        return
    await page.click('#menu button[data-button="mode:pov"]')
    await client.wait("s.menu.mode === 'pov' && s.pov.visible")
    await snapshot_until_uploaded(client, press=lambda: page.click('#menu button[data-button="camera:snapshot"]'))
    await client.frames(3)
    await client.shot("04-pov-snapshot", "desktop-pov.png")
    s = await client.state()
    await page.click('#menu button[data-button="camera:live"]')
    await client.wait("s.pov.uploads >= arg", 60, s["pov"]["uploads"] + 4)
    live_state = await client.state()
    # One texture of fixed size, reused: no texture is created per frame.
    assert live_state["textures"] == s["textures"] and live_state["pov"]["textureUuid"] == s["pov"]["textureUuid"]
    assert live_state["pov"]["mipmaps"] is False
    # What a frame costs, with and without a stream, is a benchmark's (bench/bench_client_frame.py), not this test's.
    await page.click('#menu button[data-button="camera:live"]')
    await page.click('#menu button[data-button="mode:free_roam"]')
    await client.wait("s.menu.mode === 'free_roam' && !s.menu.live")
    assert client.errors == [], client.errors
    # The robots keep their poses updated while all of this happened.
    assert math.isfinite(station.pose("robot1")[0])


async def test_a_tab_with_a_wrong_token_stops_knocking_and_says_what_to_do(browser: Browser) -> None:
    # A stale tab (the relay restarted with a new token) once retried every 5 s and had the address slowed.
    config = await asyncio.to_thread(load_config, ROOT / "robots.yaml")
    running = await start_relay(config, options=Options(token="the-current-token"))
    handshakes: list[str] = []
    page = await browser.new_page(viewport={"width": 1280, "height": 760})
    page.on("websocket", lambda ws: handshakes.append(ws.url))
    try:
        await page.goto(running.url + "/#token=last-weeks-token")
        client = Client(page, "refused")
        text = await client.wait("s.link.startsWith('refused') && s.link", 20)
        assert "wrong operator token" in text and "open the address the relay printed" in text
        await page.wait_for_timeout(6000)  # longer than the longest retry delay (5 s)
        assert len(handshakes) == 1, handshakes
        await client.shot("01-refused-token")
        # The right token in the address gets in at once.
        await page.goto(running.url + "/#token=the-current-token")
        await page.reload()
        await client.wait("s.connected", 30)
    finally:
        await page.close()
        await running.runner.cleanup()


async def test_the_demo_mission_from_the_menu_to_a_marked_region(station: Station, open_client: OpenClient) -> None:
    client = await open_client(f"{station.url}/?{SOFTWARE_GL}", "inspection")
    page = client.page
    await client.wait("s.inspection.targets === 3")
    await page.click('#menu button[data-button="mission:demo"]:not([disabled])')
    await client.wait("Object.keys(s.inspection.missions).length === 3", 30)
    await client.shot("01-mission-running")
    await client.wait("Object.values(s.inspection.missions).every((m) => m === 'done')", 120)
    state = await client.wait("s.inspection.findings.length === 3 && s.inspection.pins === 3 && s.inspection")
    assert sorted((f["target"], f["status"]) for f in state["findings"]) == [
        ("leak", "anomaly"), ("panels", "ok"), ("spill", "anomaly"),
    ]  # fmt: skip
    # The findings list: pick the spill, see its image, call it needs review, mark a region from one click.
    await page.click("#findings li[data-finding]:has-text('spill')")
    image = page.locator("#findings .capture img")
    await image.wait_for(state="visible")
    await page.wait_for_function("() => document.querySelector('#findings .capture img').naturalWidth > 0")
    await page.click('#findings button[data-status="needs_review"]')
    await client.wait("s.inspection.findings.some((f) => f.target === 'spill' && f.status === 'needs_review')")
    # The panel scrolls (its card holds readings, a trend, the statuses and a false-alarm note): the image in view.
    await image.scroll_into_view_if_needed()
    box = await image.bounding_box()
    assert box is not None
    await page.mouse.click(box["x"] + box["width"] * 0.5, box["y"] + box["height"] * 0.55)
    await page.locator('#findings button[data-region="accept"]').click(timeout=20_000)
    await client.wait("s.inspection.findings.some((f) => f.target === 'spill' && f.region)")
    await page.wait_for_selector("#findings polygon")
    await client.shot("02-finding-with-region", "findings.png")
    # Shift-click on the image: a new target where that pixel looks, named in the page's dialog.
    await image.scroll_into_view_if_needed()
    box = await image.bounding_box()
    assert box is not None
    await page.keyboard.down("Shift")
    await page.mouse.click(box["x"] + box["width"] * 0.5, box["y"] + box["height"] * 0.6)
    await page.keyboard.up("Shift")
    await name_target(client, "drum-9")
    await client.wait("s.inspection.targets === 4")
    # Shift-click on the twin's floor: a target there (the corridor in front of robot2's room).
    px, py = await page_point(client, 10.5, 2.0)
    await page.keyboard.down("Shift")
    await page.mouse.click(px, py)
    await page.keyboard.up("Shift")
    await name_target(client, "valve-4")
    await client.wait("s.inspection.targets === 5")
    valve = station.running.relay.inspection.targets["valve-4"]
    assert abs(valve.x - 10.5) < 0.3 and abs(valve.y - 2.0) < 0.3, valve
    # The report of that mission, from the panel's link: the three findings with their images; its work orders;
    # the page asking for a range.
    hrefs = await page.eval_on_selector_all("#findings .head a", "(links) => links.map((a) => a.getAttribute('href'))")
    href = hrefs[0]
    assert href is not None and href.startswith("/report/m-")
    response = await page.request.get(station.url + href)
    report = await response.text()
    assert response.ok and report.count("data:image/jpeg;base64,") == 3 and "Needs review" in report
    assert hrefs[1] == href.replace(".html", ".workorders.csv") and hrefs[2].startswith("/report/range.html"), hrefs
    orders = await page.request.get(station.url + hrefs[1])
    assert orders.ok and (await orders.text()).startswith("reference,asset,asset_name,location")
    # A mission made in the page: pick the leak, then the spill, for the fleet.
    await page.click("#findings li[data-target='leak']")
    await page.click("#findings li[data-target='spill']")
    order = {t: await page.inner_text(f"#findings li[data-target='{t}'] .order") for t in ("leak", "spill", "panels")}
    assert order == {"leak": "1", "spill": "2", "panels": ""}
    await page.click('#findings button[data-mission="start"]')
    # Each robot inspects its target again (it stands next to it since the demo): two new findings.
    await client.wait("s.inspection.findings.length === 5", 60)
    # A false alarm, with the note typed beside its button: the list says so in words, the database keeps the note.
    await page.click("#findings li[data-finding]:has-text('leak') >> nth=0")
    await page.fill("#findings input[data-note]", "condensation on the lens")
    await page.click("#findings button[data-false-alarm]")
    await client.wait("s.inspection.findings.some((f) => f.target === 'leak' && f.status === 'false_alarm')")
    await page.wait_for_selector("#findings li[data-finding]:has-text('False alarm')")
    store = station.running.relay.inspection.store
    assert store is not None
    assert [f.note for f in store.findings(status="false_alarm")] == ["condensation on the lens"]
    assert not client.errors, client.errors


async def test_a_software_renderer_is_detected_and_quality_lowered_by_itself(
    station: Station, browser: Browser, open_client: OpenClient
) -> None:
    # No ?quality or ?maxfps: Debian's Chromium here draws with SwiftShader, and the page notices by itself. It says
    # so for 8 s from the start: read while the page loads (a loaded machine took longer to load the twin).
    page = await browser.new_page(viewport={"width": 1280, "height": 760})
    client = Client(page, "quality")  # before the page loads: it hears the page's errors from the start
    await page.goto(f"{station.url}/?name=Tess")
    said = await page.wait_for_function(
        "() => { const m = document.querySelector('#message'); "
        "return m && m.textContent.startsWith('software rendering (') && m.textContent; }",
        timeout=30_000,
        polling=50,
    )
    message = await said.json_value()
    assert "?quality=high" in message, message
    await client.wait("s.connected && Object.keys(s.robots).length > 0 && s.twin.state !== 'loading'", 30)
    quality = await client.page.evaluate("window.__xrRelay.quality")
    assert quality["software"] is True and quality["lowQuality"] is True and quality["maxFps"] == 10, quality
    # What the page does with it: 0.75 resolution, at most 10 drawn frames a second, every robot the shared shape.
    s = await client.state()
    assert s["draw"]["pixelRatio"] == 0.75 and s["draw"]["maxFps"] == 10 and s["draw"]["detailedMax"] == 0, s["draw"]
    assert not any(r["detailed"] for r in s["robots"].values()), s["robots"]
    # ?quality=high: the operator asked for full quality; nothing is lowered or said.
    full = await open_client(f"{station.url}/?quality=high", "quality-high", 640, 400)
    quality = await full.page.evaluate("window.__xrRelay.quality")
    assert quality == {"lowQuality": False, "maxFps": None, "software": True, "reason": "", "detailedMax": 4}, quality
    draw = (await full.state())["draw"]
    assert draw["pixelRatio"] == 1 and draw["maxFps"] is None, draw  # headless Chromium: device pixel ratio 1
    # and the demo's three robots with their full models (the nearest four are: level_of_detail.js).
    await full.wait("Object.values(s.robots).filter((r) => r.detailed).length === 3", 30)
    assert client.errors == [] and full.errors == [], (client.errors, full.errors)
    await page.close()
