"""The operator's experience (issue #14), each moment that used to leave an operator unsure, on the desktop and
in VR through IWER: what they see and what the robots do, waiting on `window.__xrRelay.state` and checking the
relay's side. Screenshots go to test-artifacts/ (and docs/img with XR_RELAY_DOC_IMAGES=1)."""

from __future__ import annotations

import math
import time

from .conftest import OpenClient, Station, wait_until
from .test_client_vr import enter_vr
from .xr_helpers import aim, button, click, press_menu_button, set_menu

ROBOTS = ("robot1", "robot2", "robot3")


def latched(station: Station) -> list[str]:
    return [r for r in ROBOTS if station.status(r)["estopped"]]


async def test_estop_by_key_while_driving_holds_view_and_robot_and_stays_until_reset(
    station: Station, open_client: OpenClient
) -> None:
    client = await open_client(station.url, "estop")
    page = client.page
    await page.click('#menu button[data-button="robot:robot1"]')
    await page.click('#menu button[data-button="tool:teleop"]')
    await client.wait("s.menu.tool === 'teleop'")
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
    await page.click('#estop-banner button[data-button="estop:reset"]')
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
    await page.click('#estop-banner button[data-button="estop:reset"]')
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
    await press_menu_button(client, "estop:reset")
    await wait_until(lambda: latched(station) == [], 5, "released")
    assert client.errors == [], client.errors
