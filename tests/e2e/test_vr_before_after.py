"""A changed finding's card in VR (issue 30, item 4): opened by pointing at its pin, it shows the capture (after)
and, with its Before button, the capture of the last round it was compared with; After brings the new one back.
The two rounds are the spill as the simulator renders it, compared by the relay's own comparison
(tests/helpers/inspection.py two_rounds)."""

from __future__ import annotations

from tests.helpers.browser import OpenClient, Station
from tests.helpers.inspection import two_rounds
from tests.helpers.xr import aim, click, enter_vr, press_menu_button, set_menu


async def test_a_changed_findings_card_in_vr_shows_the_round_before_and_after(
    station: Station, open_client: OpenClient
) -> None:
    _, changed, _ = await two_rounds(station.running)
    client = await enter_vr(open_client, station.url)
    await set_menu(client, True)
    await press_menu_button(client, "robot:robot1")
    await press_menu_button(client, "tool:inspect")
    await client.wait("s.menu.tool === 'inspect'")
    await set_menu(client, False)
    await client.wait("arg in s.inspection.pinLooks", 30, changed.id)

    async def point_and_select(point: list[float], hover: str) -> None:
        await aim(client, "right", point)
        await client.wait("s.xr.hover.right === arg", 20, hover)
        await click(client, "right")

    pin = await client.page.evaluate("([x, y]) => window.__xrRelay.mapToScene(x, y, 1.25)", [changed.x, changed.y])
    await point_and_select(pin, f"insp:finding:{changed.id}")
    card = await client.wait("(c => c.visible && c.image && c.before === 'loaded' && c)(s.inspection.card)", 30)
    assert card["showing"] == "after", card
    after_draws = card["draws"]
    points = await client.page.evaluate("() => window.__xrRelay.cardPoints(null)")
    await point_and_select(points["card:before"], "insp:card:card:before")
    await client.wait("s.inspection.card.showing === 'before' && s.inspection.card.draws > arg", 10, after_draws)
    await client.frames(3)
    await client.shot("01-before", "vr-before-after.png")
    await point_and_select(points["card:after"], "insp:card:card:after")
    await client.wait("s.inspection.card.showing === 'after'", 10)
    assert client.errors == [], client.errors
