"""The desktop's alerts list (issue 30, item 2): an alert the relay raises appears above the findings with a count
badge, and its Acknowledge button sends alert/ack under the page's operator name; the alert then leaves the list, and
after a reload only the others are listed again.
However many alerts the menu lists, its E-STOP stays where the operator can click it."""

from __future__ import annotations

from tests.helpers.browser import SOFTWARE_GL, OpenClient, Station, covered
from tests.helpers.inspection import stored_alert


async def test_an_alert_is_acknowledged_from_the_desktop_list(station: Station, open_client: OpenClient) -> None:
    client = await open_client(f"{station.url}/?{SOFTWARE_GL}", "alerts", 1280, 760, operator="Tess")
    page = client.page
    inspection = station.running.relay.inspection
    alert = inspection.raise_alert(
        "threshold", "Past its limit at Spill (robot1): gas 698.2 ppm (over 400 ppm)", robot="robot1",
        severity="critical",
    )  # fmt: skip
    for n in range(4):  # more alerts: the menu's alert rows grow past a 760-pixel window
        inspection.raise_alert("schedule_missed", f"Schedule s-night missed run {n}: relay was down", robot="robot2")
    item = f"#findings li[data-alert='{alert.id}']"
    await page.wait_for_selector(item, timeout=30_000)
    await page.wait_for_selector("#findings .badge:text('5')", timeout=30_000)
    # The E-STOP row heads the menu, above anything the menu or the help box can grow to; the menu's last button is
    # reached by scrolling the menu, not hidden under the help box.
    assert await covered(page, "#menu .row.estop button") == []
    last = '#menu button[data-button="opt:ticks"]'  # in the menu's last row: sound
    assert await covered(page, last) == ["opt:ticks"]  # below the menu's fold, above the help box
    await page.locator(last).scroll_into_view_if_needed()
    assert await covered(page, f"#menu .row.estop button, {last}") == []
    await client.shot("01-many-alerts")
    assert "gas 698.2 ppm" in await page.inner_text(item)
    await page.click(f"#findings button[data-ack='{alert.id}']")
    await page.wait_for_selector(item, state="detached", timeout=30_000)
    assert await page.inner_text("#findings .badge") == "4"
    acknowledged = await stored_alert(station.running, alert.id)
    assert acknowledged is not None and acknowledged.acked_by == "Tess"
    # A reload is a new connection: the four nobody acknowledged are listed again, the acknowledged one is not.
    await page.reload()
    await page.wait_for_selector("#findings .badge:text('4')", timeout=30_000)
    assert await page.locator("#findings li[data-alert]").count() == 4
    assert await page.locator(item).count() == 0
