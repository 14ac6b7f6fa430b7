"""Pins coloured by change since the last round, and the "since last round" filter (issue 30, item 4): two rounds of
the spill as the simulator renders them, compared by the relay's own comparison and stored and announced through its
own capture path, make a ``changed`` finding in the second round; beside it in that round an unchanged finding. The
changed pin takes the change colour (orange to magenta, xr_client/src/change_colour.js), the unchanged one keeps its
status colour, and the filter (the desktop panel's switch, the menu's pair) hides the unchanged one and brings it
back when off."""

from __future__ import annotations

from tests.helpers.browser import SOFTWARE_GL, OpenClient, Station
from tests.helpers.inspection import two_rounds

#: The ok status's pin colour (xr_client/src/change_colour.js STATUS_COLOURS.ok).
OK_GREEN = "#2e9e4f"


async def test_changed_pins_take_the_change_colour_and_the_filter_keeps_only_them(
    station: Station, open_client: OpenClient
) -> None:
    old, changed, same = await two_rounds(station.running)
    client = await open_client(f"{station.url}/?{SOFTWARE_GL}", "change-pins", 1280, 760)
    page = client.page
    ids = [old.id, changed.id, same.id]
    looks = await client.wait("[...arg].every((id) => id in s.inspection.pinLooks) && s.inspection.pinLooks", 30, ids)
    colour = looks[changed.id]["colour"]
    red, green, blue = (int(colour[i : i + 2], 16) for i in (1, 3, 5))
    # Orange (#ff7f00) at the threshold to magenta (#ff00ff) from 0.3: this score, a few percent, in between.
    assert red == 0xFF and green < 0x7F and 0 < blue < 0xFF, colour
    assert looks[changed.id]["label"] == f"Changed {changed.change * 100:.1f} %", looks  # type: ignore[operator]
    assert looks[same.id]["colour"] == OK_GREEN and looks[old.id]["colour"] == OK_GREEN, looks
    dot = page.locator(f"#findings li[data-finding='{changed.id}'] .dot")
    assert await dot.evaluate("(d) => getComputedStyle(d).backgroundColor") == f"rgb({red}, {green}, {blue})"
    # On (the panel's switch): what changed in each target's newest round alone, pins and rows; the menu follows.
    await page.check("#findings input[data-since]")
    shown = "s.inspection.sinceLastRound && Object.keys(s.inspection.pinLooks).join() === arg"
    await client.wait(shown, 10, changed.id)
    await page.wait_for_selector(f"#findings li[data-finding='{same.id}']", state="detached")
    assert await page.locator("#findings li[data-finding]").count() == 1
    await page.wait_for_selector('#menu button[data-button="findings:since"][aria-pressed="true"]', state="attached")
    await client.shot("01-since-last-round", "change-pins.png")
    # Off (the menu's All findings): every pin again, the unchanged one in its status colour.
    await page.click('#menu button[data-button="findings:all"]')
    await client.wait("!s.inspection.sinceLastRound && arg.every((id) => id in s.inspection.pinLooks)", 10, ids)
    assert await page.locator("#findings li[data-finding]").count() == 3
    assert not await page.is_checked("#findings input[data-since]")
    assert not client.errors, client.errors
