"""Issue #31, finding 3 in VR (IWER's emulated Quest 3 in Chromium): the latched E-STOP is an alarm in the view (a
red banner, not a small grey card), and the start faces the fleet from a spot with room when the robots are spread
over the rooms (it started 0.5 m from a blank wall with robot1 88 degrees off the view), with the overview table
where nothing covers it (it was half behind the wrist panel)."""

from __future__ import annotations

import asyncio
from pathlib import Path

from PIL import Image

from .conftest import OpenClient, Station, wait_until
from .test_client_vr import enter_vr
from .xr_helpers import button, press_menu_button, set_menu

ROBOTS = ("robot1", "robot2", "robot3")


def latched(station: Station) -> list[str]:
    return [r for r in ROBOTS if station.status(r)["estopped"]]


def alarm_red_share(path: Path, box: tuple[float, float, float, float]) -> float:
    """The share of a screenshot's pixels in ``box`` (fractions of its width and height: left, top, right, bottom)
    that are the banner's saturated red (the twin's walls, floor and sky are greys and blues)."""
    with Image.open(path) as image:
        rgb = image.convert("RGB")
        w, h = rgb.size
        crop = rgb.crop((int(box[0] * w), int(box[1] * h), int(box[2] * w), int(box[3] * h)))
        pixels = list(crop.getdata())
    red = sum(1 for r, g, b in pixels if r > 170 and g < 80 and b < 80)
    return red / len(pixels)


async def test_a_latched_estop_is_a_red_alarm_in_the_middle_of_the_view(
    station: Station, open_client: OpenClient
) -> None:
    client = await enter_vr(open_client, station.url)
    await client.frames(3)
    quiet = await client.shot("20-before-estop")
    # The upper middle of the view, where the banner hangs (13 degrees over the centre).
    upper_middle = (0.2, 0.1, 0.8, 0.5)
    before = await asyncio.to_thread(alarm_red_share, quiet, upper_middle)
    await button(client, "left", "x-button", 1)
    await wait_until(lambda: latched(station) == list(ROBOTS), 5, "every robot latched by X")
    await button(client, "left", "x-button", 0)
    await client.wait("s.estop.vr", 5)
    await client.frames(3)
    alarm = await client.shot("21-estop-alarm")
    after = await asyncio.to_thread(alarm_red_share, alarm, upper_middle)
    # The banner is 45 x 9 degrees of the view, most of it alarm red: 6-7 % of that region in IWER's picture (a grey
    # card with a red bar, before: under 1 %).
    assert after > 0.04 and before < 0.01, (before, after)
    # Turned 40 degrees to the right, the alarm is still there, in the middle of the view.
    await client.page.evaluate("() => window.__iwer.quaternion.set(0, -0.342, 0, 0.9397)")
    await client.frames(3)
    turned = await client.shot("22-estop-alarm-turned")
    assert await asyncio.to_thread(alarm_red_share, turned, upper_middle) > 0.04
    await client.page.evaluate("() => window.__iwer.quaternion.set(0, 0, 0, 1)")
    # Opening the menu does not hide it, and it hides none of the menu: the menu's top is under it.
    await set_menu(client, True)
    await client.frames(3)
    over_menu = await client.shot("23-estop-alarm-over-menu")
    assert await asyncio.to_thread(alarm_red_share, over_menu, upper_middle) > 0.04
    await press_menu_button(client, "estop:reset")
    await wait_until(lambda: latched(station) == [], 5, "released from the menu")
    await client.wait("!s.estop.vr")
    assert client.errors == [], client.errors
