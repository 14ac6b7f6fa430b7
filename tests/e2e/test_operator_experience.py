"""The operator's experience (issue #14), each moment that used to leave an operator unsure, on the desktop and
in VR through IWER: what they see and what the robots do, waiting on `window.__xrRelay.state` and checking the
relay's side. Screenshots go to test-artifacts/ (and docs/img with XR_RELAY_DOC_IMAGES=1)."""

from __future__ import annotations

import contextlib
import math
import os
import signal
import time
from pathlib import Path

from playwright.async_api import Browser

from relay.session.clients import roster
from tests.conftest import relay_process
from tests.helpers.browser import (
    SOFTWARE_GL,
    Client,
    OpenClient,
    Station,
    choose,
    confirm_reset,
    goal_at_backend,
    wait_until,
)
from tests.helpers.xr import aim, aim_arc, button, click, enter_vr, press_menu_button, reset_in_vr, set_menu

ROBOTS = ("robot1", "robot2", "robot3")


def latched(station: Station) -> list[str]:
    return [r for r in ROBOTS if station.status(r)["estopped"]]


async def test_estop_by_key_while_driving_holds_view_and_robot_and_stays_until_reset(
    station: Station, open_client: OpenClient
) -> None:
    client = await open_client(f"{station.url}/?{SOFTWARE_GL}", "estop")
    page = client.page
    await choose(client, "robot1", "teleop")
    await page.locator("#viewport canvas").focus()
    pushed = time.monotonic()
    await page.keyboard.down("KeyW")
    await wait_until(
        lambda: any(lin > 0.3 for _, lin, _ in station.velocities_of("robot1", pushed)), 10, "robot1 driven"
    )

    # Space, with W still held: every robot stops and latches, and the banner says so.
    await page.keyboard.press("Space")
    await wait_until(lambda: latched(station) == list(ROBOTS), 5, "every robot latched")
    stopped = time.monotonic()
    s = await client.wait("s.estop.page && s.estop", 5)
    assert s["banner"] == "ALL ROBOTS E-STOPPED · by you" and s["fleet"] is True
    # Teleop went off under the held W: neither the robot nor the view moves.
    camera = (await client.state())["camera"]
    await client.drawn(5)
    assert math.dist(camera, (await client.state())["camera"]) < 1e-9, "the held W flew the view away"
    assert all(lin == 0 and ang == 0 for _, lin, ang in station.velocities_of("robot1", stopped))
    # The notice fades; the banner stays until the latch is reset.
    await client.wait("!document.querySelector('#message').textContent", 12)
    assert (await client.state())["estop"]["page"] is True
    await page.keyboard.up("KeyW")
    await client.shot("01-estop-banner", "estop-banner.png")
    # The reset asks first, naming whose E-STOP it lifts; Keep keeps it.
    await page.click('#estop-banner button[data-button="estop:reset"]')
    await page.click('#confirm-dialog button[value="no"]')
    await client.drawn(2)
    assert latched(station) == list(ROBOTS)
    question = await confirm_reset(page)
    assert question.startswith("Reset the E-STOP pressed by you on all robots?"), question
    await wait_until(lambda: latched(station) == [], 5, "every robot released")
    await client.wait("s.estop.banner === null && !s.estop.page")

    # A robot's own stop stops only it; Esc stops the whole fleet.
    await page.click('#menu button[data-button="estop:robot"]')
    await wait_until(lambda: latched(station) == ["robot1"], 5, "robot1 alone latched")
    s = await client.wait("s.estop.banner && s.estop")
    assert s["banner"] == "E-STOPPED: robot1 · by you" and s["fleet"] is False
    await page.keyboard.press("Escape")
    await wait_until(lambda: latched(station) == list(ROBOTS), 5, "Esc latched the fleet")
    await client.wait("s.estop.fleet")
    await confirm_reset(page)
    await wait_until(lambda: latched(station) == [], 5, "released again")
    assert client.errors == [], client.errors


async def test_vr_estop_within_reach_on_a_button_and_the_wrist(station: Station, open_client: OpenClient) -> None:
    client = await enter_vr(open_client, station.url)
    # X on the left controller: everything stops, and the banner at the top of the view stays.
    await button(client, "left", "x-button", 1)
    await wait_until(lambda: latched(station) == list(ROBOTS), 5, "every robot latched by X")
    s = await client.wait("s.estop.vr && s.estop", 5)
    assert s["banner"] == "ALL ROBOTS E-STOPPED · by you"
    await button(client, "left", "x-button", 0)
    await client.frames(3)
    await client.shot("10-estop-banner", "vr-estop.png")
    await set_menu(client, True)
    await press_menu_button(client, "estop:reset")
    notice = await client.wait("s.notice.startsWith('Reset the E-STOP') && s.notice", 10)
    assert "pressed by you on all robots" in notice and "again to confirm" in notice, notice
    assert latched(station) == list(ROBOTS), "one press reset the E-STOP: no confirmation"
    await reset_in_vr(client, armed=True)
    await wait_until(lambda: latched(station) == [], 5, "released from the menu")
    await client.wait("!s.estop.vr")
    await set_menu(client, False)

    # The E-STOP under the wrist panel: the right hand's ray presses it.
    s = await client.wait("s.estop.points.wrist && s.estop", 10)
    await aim(client, "right", s["points"]["wrist"])
    await client.wait("s.xr.hover.right === 'estop'", 10)
    await click(client, "right")
    await wait_until(lambda: latched(station) == list(ROBOTS), 5, "every robot latched from the wrist")
    await client.wait("s.estop.vr")
    await set_menu(client, True)
    await reset_in_vr(client)
    await wait_until(lambda: latched(station) == [], 5, "released")
    assert client.errors == [], client.errors


async def test_goal_mode_says_what_a_click_would_do_and_a_click_on_a_robot_selects_it(
    station: Station, open_client: OpenClient
) -> None:
    client = await open_client(f"{station.url}/?{SOFTWARE_GL}", "goal-verdict")
    page = client.page
    await choose(client, "robot1", "goal")

    async def hover(x: float, y: float) -> dict[str, object]:
        px, py = await page.evaluate("([x, y]) => window.__xrRelay.mapToPage(x, y, 0)", [x, y])
        await page.mouse.move(px, py)
        goal: dict[str, object] = await client.wait("s.goal.verdict && s.goal", 10)
        return goal

    # On robot2: white, "select robot2"; the click selects it and sends no goal.
    goal = await hover(9.0, 1.5)
    assert goal["verdict"] == {"kind": "select", "robot": "robot2"} and goal["colour"] == "#ffffff", goal
    await page.mouse.down()
    await page.mouse.up()
    await client.wait("s.menu.selected === 'robot2'")
    await client.shot("02-click-on-a-robot-selects-it")
    await page.click('#menu button[data-button="robot:robot1"]')
    await client.wait("s.menu.selected === 'robot1' && s.menu.tool === 'goal'")

    # Next to robot2: red, with the reason, and the click says it and sends nothing.
    goal = await hover(9.5, 1.35)  # 0.52 m east of robot2, clear of its label
    verdict = goal["verdict"]
    assert isinstance(verdict, dict) and verdict["kind"] == "refused" and goal["colour"] == "#e02424", goal
    assert verdict["reason"].startswith("too close to robot2")
    tip = await page.inner_text("#cursor-tip")
    assert tip.startswith("can't go there: too close to robot2 (0.5 m"), tip
    await client.drawn(2)
    await client.shot("03-refused-next-to-robot2", "goal-refused.png")
    await page.mouse.down()
    await page.mouse.up()
    await client.wait("document.querySelector('#message').textContent.startsWith('No goal here: too close to robot2')")
    # The wall between chemical storage and power distribution: refused as a wall.
    goal = await hover(6.0, 6.0)
    assert goal["verdict"] == {"kind": "refused", "reason": "a wall or an obstacle: point at the floor"}, goal
    assert (await client.state())["goal"]["sent"] == 0 and station.goals == []

    # The floor of power distribution: blue, and a click sends robot1 there.
    goal = await hover(9.0, 6.0)
    assert goal["verdict"] == {"kind": "goal"} and goal["colour"] == "#3d8bff", goal

    async def press() -> None:
        await page.mouse.down()
        await page.mouse.up()

    await press()
    assert (await goal_at_backend(station, press))[0] == "robot1"
    assert client.errors == [], client.errors


async def test_vr_arc_on_a_robot_selects_it_and_a_wall_is_refused(station: Station, open_client: OpenClient) -> None:
    client = await enter_vr(open_client, station.url)
    await set_menu(client, True)
    await press_menu_button(client, "robot:robot2")
    await press_menu_button(client, "tool:goal")
    await set_menu(client, False)
    # The corridor's north wall, between two doors: red, and the trigger sends nothing.
    wall = await client.page.evaluate("() => window.__xrRelay.mapToScene(5.5, 3.0, 0)")
    await aim_arc(client, "right", wall)
    refused = await client.wait("s.goal.verdict && s.goal.verdict.kind === 'refused' && s.goal", 10)
    assert refused["verdict"]["reason"] == "a wall or an obstacle: point at the floor"
    assert refused["colour"] == "#e02424"
    await click(client, "right")
    # The arc on robot1: white, and the trigger selects robot1 instead of sending robot2 into it.
    robot1 = await client.page.evaluate("() => window.__xrRelay.mapToScene(3.0, 1.5, 0)")
    await aim_arc(client, "right", robot1)
    try:
        await client.wait("s.goal.verdict && s.goal.verdict.kind === 'select' && s.goal.verdict.robot === 'robot1'", 10)
    except Exception as exc:
        s = await client.state()
        raise AssertionError(f"no select on robot1: {s['goal']}, robot1 drawn at {s['robots']['robot1']}") from exc
    await click(client, "right")
    await client.wait("s.menu.selected === 'robot1'")
    assert (await client.state())["goal"]["sent"] == 0
    assert client.errors == [], client.errors


async def test_the_plan_is_drawn_and_the_outcome_said(station: Station, open_client: OpenClient) -> None:
    client = await open_client(f"{station.url}/?{SOFTWARE_GL}", "path")
    page = client.page
    await choose(client, "robot2", "goal")
    px, py = await page.evaluate("([x, y]) => window.__xrRelay.mapToPage(x, y, 0)", [9.0, 6.0])
    await page.mouse.move(px, py)
    await client.wait("s.goal.verdict && s.goal.verdict.kind === 'goal'", 10)
    await page.mouse.down()
    await page.mouse.up()
    # The plan the sim follows, drawn ahead of robot2 in its colour, and the goal's ring until it is reached.
    s = await client.wait("s.paths.robot2 >= 2 && s.markers.robot2 && s", 15)
    await client.drawn(2)
    await client.shot("04-path-ahead", "goal-path.png")
    assert s["paths"]["robot2"] >= 2
    await client.wait("document.querySelector('#message').textContent === 'robot2 reached its goal (9.0, 6.0)'", 60)
    s = await client.wait("!s.paths.robot2 && !s.markers.robot2 && s", 5)
    assert station.status("robot2")["goal"] is None
    assert client.errors == [], client.errors


async def test_vr_starts_seeing_the_fleet_and_sends_robot1_to_chemical_storage_from_the_overview(
    station: Station, open_client: OpenClient
) -> None:
    """As a new operator: Enter VR, and without teleporting, select robot1 and send it into chemical storage."""
    client = await enter_vr(open_client, station.url)
    s = await client.wait("s.overview.visible && s.overview.arrows === 3 && s", 10)
    start = s["rig"]["position"]
    # The start (start_pose.js): every robot in front, within the view, none hidden by a wall.
    for robot in ROBOTS:
        x, _, z = s["robots"][robot]["position"]
        forward = (-math.sin(s["rig"]["yaw"]), -math.cos(s["rig"]["yaw"]))
        to_robot = (x - start[0], z - start[2])
        angle = math.degrees(math.acos((forward[0] * to_robot[0] + forward[1] * to_robot[1]) / math.hypot(*to_robot)))
        assert angle <= 45, f"{robot} is {angle:.0f} degrees off the view"
    await client.shot("11-start-with-overview", "vr-start.png")

    async def point_at_table(x: float, y: float) -> None:
        point = await client.page.evaluate("([x, y]) => window.__xrRelay.overviewPoint(x, y)", [x, y])
        await aim(client, "right", point)
        await client.wait("s.xr.hover.right === 'wim'", 10)

    # robot1 on the table: the cursor says select, the trigger selects it.
    await point_at_table(3.0, 1.5)
    try:
        await client.wait("s.overview.cursor && s.overview.cursor.verdict.robot === 'robot1'", 10)
    except Exception as exc:
        s = await client.state()
        raise AssertionError(f"the table's cursor: {s['overview']}, hover {s['xr']['hover']}") from exc
    await click(client, "right")
    await client.wait("s.menu.selected === 'robot1'")
    await set_menu(client, True)
    await press_menu_button(client, "tool:goal")
    await set_menu(client, False)
    # Chemical storage's floor on the table: a goal there, pressed and released on the table.
    await point_at_table(3.0, 6.5)
    await client.wait("s.goal.verdict && s.goal.verdict.kind === 'goal'", 10)

    async def pull() -> None:
        await button(client, "right", "trigger", 1)
        await client.wait("s.goal.pointer === 'placing'")
        await button(client, "right", "trigger", 0)

    await pull()
    await client.wait("s.goal.sent === 1")
    robot, gx, gy, _ = await goal_at_backend(station, pull)
    assert robot == "robot1" and math.hypot(gx - 3.0, gy - 6.5) < 0.15, station.goals
    assert (await client.state())["rig"]["position"] == start, "the operator did not move"
    await wait_until(lambda: station.status("robot1")["mode"] == "navigating", 10, "robot1 on its way")
    # Looking down at the table (the emulated headset pitched 35 degrees), for the picture.
    await client.page.evaluate("() => window.__iwer.quaternion.set(-0.3007, 0, 0, 0.9537)")
    await client.frames(4)
    await client.shot("12-goal-from-the-overview", "vr-overview-goal.png")
    assert client.errors == [], client.errors


async def test_a_frozen_relay_shows_old_data_as_old_and_a_restart_says_reconnected(
    browser: Browser, tmp_path: Path
) -> None:
    args = ("--token", "t", "--allow-weak-token", "--audit-log", "", "--database", str(tmp_path / "inspection.sqlite"))
    relay, base = await relay_process(*args)
    page = await browser.new_page(viewport={"width": 1280, "height": 760})
    client = Client(page, "stale")
    try:
        await page.goto(f"{base}/?{SOFTWARE_GL}#token=t")
        await client.wait("s.connected && Object.keys(s.robots).length === 3 && s.twin.state !== 'loading'", 30)
        await page.click('#menu button[data-button="robot:robot1"]')
        await client.wait("s.panel.sensors.length === 3 && s.panel.sensors.every((x) => x.value !== null)", 20)
        live = await client.state()
        assert not any(r["stale"] for r in live["robots"].values())

        # Frozen: the link stays open, nothing comes. Robots and readings turn grey with their age, not "live".
        os.kill(relay.pid, signal.SIGSTOP)
        s = await client.wait(
            "Object.values(s.robots).every((r) => r.stale) && s.panel.sensors.every((x) => x.stale) && s", 10
        )
        await client.wait("document.querySelector('#link-status').textContent.includes('no answer for')", 10)
        label = s["robots"]["robot1"]["label"]
        assert "was idle" in label and ("no pose for" in label or "relay silent" in label), label
        await client.drawn(2)
        await client.shot("01-frozen-relay", "stale.png")
        # The page gives up on the silent socket (no pong in 6 s) and says the connection is lost.
        await client.wait(
            "!s.connected && Object.values(s.robots).every((r) => r.stale.startsWith('connection lost'))", 20
        )
        relay.kill()
        await relay.wait()

        # A relay on the same address again: the page reconnects, says so, and shows the fleet live again; the
        # sparklines keep the hole where nothing came.
        relay, _ = await relay_process(*args, port=int(base.rsplit(":", 1)[1]))
        await client.wait("s.connected && Object.values(s.robots).every((r) => !r.stale)", 40)
        await client.wait("document.querySelector('#message').textContent.startsWith('Reconnected')", 10)
        s = await client.wait("s.panel.sensors.every((x) => !x.stale && x.gaps >= 1) && s", 20)
        await client.shot("02-reconnected")
        # The browser logs the attempts made while nothing listened; nothing else went wrong.
        assert [e for e in client.errors if "ERR_CONNECTION_REFUSED" not in e] == [], client.errors
    finally:
        await page.close()
        if relay.returncode is None:
            with contextlib.suppress(ProcessLookupError):
                os.kill(relay.pid, signal.SIGCONT)
            relay.kill()
            await relay.wait()


async def test_operators_have_names_and_take_over_in_the_page_with_the_goal_sent(
    station: Station, open_client: OpenClient
) -> None:
    ana = await open_client(f"{station.url}/?name=Ana&{SOFTWARE_GL}", "lease-ana")
    ben = await open_client(f"{station.url}/?{SOFTWARE_GL}", "lease-ben", operator=None)
    # Ben is asked once, in the page (not modal: the station stays usable meanwhile), and remembered.
    await ben.page.wait_for_selector("#name-dialog[open]")
    assert not await ana.page.is_visible("#name-dialog"), "a name from the address is not asked again"
    await ben.page.fill("#name-dialog input", "Ben")
    await ben.page.click("#name-dialog button[value=ok]")
    await wait_until(
        lambda: sorted(roster(station.running.relay.commands.clients).values()) == ["Ana", "Ben"], 10, "both named"
    )
    assert await ben.page.evaluate("() => localStorage.getItem('xr-relay-operator-name')") == "Ben"

    # Ana sends robot1 down the corridor: Ben reads "Ana" on it, Teleop is off for him, Take over is offered.
    for page, robot in ((ana.page, "robot1"), (ben.page, "robot1")):
        await page.click(f'#menu button[data-button="robot:{robot}"]')
    await ana.page.click('#menu button[data-button="tool:goal"]')
    px, py = await ana.page.evaluate("([x, y]) => window.__xrRelay.mapToPage(x, y, 0)", [6.0, 2.0])
    await ana.page.mouse.click(px, py)
    await wait_until(lambda: station.status("robot1")["mode"] == "navigating", 10, "robot1 navigating for Ana")
    await ben.wait("s.robots.robot1.label.includes('navigating · Ana')", 10)
    s = await ben.wait("s.menu.buttons.some((b) => b.id === 'lease:take') && s", 10)
    teleop = next(b for b in s["menu"]["buttons"] if b["id"] == "tool:teleop")
    assert teleop["label"] == "Teleop (held by Ana)" and teleop["enabled"] is False
    assert next(b for b in s["menu"]["buttons"] if b["id"] == "lease:take")["label"] == "Take over from Ana"

    # Ben's Goal click on the floor says what it will do, and the in-page dialog takes over and sends the goal.
    await ben.page.click('#menu button[data-button="tool:goal"]')
    px, py = await ben.page.evaluate("([x, y]) => window.__xrRelay.mapToPage(x, y, 0)", [3.0, 6.0])
    await ben.page.mouse.move(px, py)
    goal = await ben.wait("s.goal.verdict && s.goal.verdict.kind === 'takeover' && s.goal", 10)
    assert goal["verdict"]["holder"] == "Ana" and goal["colour"] == "#ffb020"
    await ben.page.mouse.click(px, py)
    await ben.page.wait_for_selector("#takeover-dialog[open]")
    text = await ben.page.inner_text("#takeover-dialog p")
    assert text.startswith("robot1 is controlled by Ana. Take it over? It stops first"), text
    await ben.shot("01-take-over-dialog", "takeover.png")
    await ben.page.click('#takeover-dialog button[value="take"]')
    ben_id = (await ben.state())["clientId"]
    await wait_until(lambda: station.status("robot1")["controller"] == ben_id, 10, "robot1 held by Ben")
    await wait_until(
        lambda: (g := station.status("robot1")["goal"]) is not None and abs(g["y"] - 6.0) < 0.3, 10, "Ben's goal"
    )
    await ana.wait("document.querySelector('#message').textContent === 'robot1 was taken over by Ben'", 10)
    await ana.wait("s.robots.robot1.label.includes('Ben')", 10)
    assert ana.errors == [] and ben.errors == [], (ana.errors, ben.errors)


async def test_the_sensor_panel_reads_against_thresholds_and_gas_is_never_negative(
    station: Station, open_client: OpenClient
) -> None:
    client = await open_client(f"{station.url}/?{SOFTWARE_GL}", "sensors")
    await client.page.click('#menu button[data-button="robot:robot1"]')
    # Half a minute of 5 Hz readings in the corridor: 5 ppm of gas with 2 ppm of noise, 400 ppm to warn.
    s = await client.wait("s.panel.sensors.length === 3 && s.panel.sensors.every((x) => x.value !== null) && s", 20)
    started = time.monotonic()
    await wait_until(lambda: time.monotonic() - started > 8, 10, "readings to gather")
    s = await client.state()
    gas = next(x for x in s["panel"]["sensors"] if x["name"] == "gas")
    assert gas["lowest"] >= 0.0, gas
    # Each sparkline spans its threshold (drawn dashed): the noise stays a thin band, not a box-filling alarm.
    assert all(x["thresholds"] == 1 for x in s["panel"]["sensors"]), s["panel"]
    assert gas["spread"] < 4.0, gas  # of a 40 px box
    await client.shot("01-sensor-panel", "sensor-panel.png")
    assert client.errors == [], client.errors
