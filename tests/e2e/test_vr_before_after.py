"""A changed finding's card in VR (issue 30, item 4): opened by pointing at its pin, it shows the capture (after)
and, with its Before button, the capture of the last round it was compared with; After brings the new one back.
The two rounds are the spill as the simulator renders it, compared by the relay's own comparison
(tests/helpers/inspection.py two_rounds)."""

from __future__ import annotations

from tests.helpers.browser import OpenClient, Station
from tests.helpers.inspection import two_rounds
from tests.helpers.xr import enter_vr, open_finding_card, press_card_button


async def test_a_changed_findings_card_in_vr_shows_the_round_before_and_after(
    station: Station, open_client: OpenClient
) -> None:
    _, changed, _ = await two_rounds(station.running)
    client = await enter_vr(open_client, station.url)
    await open_finding_card(client, changed.id, changed.x, changed.y)
    card = await client.wait("(c => c.visible && c.image && c.before === 'loaded' && c)(s.inspection.card)", 30)
    assert card["showing"] == "after", card
    after_draws = card["draws"]
    await press_card_button(client, "card:before")
    await client.wait("s.inspection.card.showing === 'before' && s.inspection.card.draws > arg", 10, after_draws)
    await client.frames(3)
    await client.shot("01-before", "vr-before-after.png")
    await press_card_button(client, "card:after")
    await client.wait("s.inspection.card.showing === 'after'", 10)
    assert client.errors == [], client.errors
