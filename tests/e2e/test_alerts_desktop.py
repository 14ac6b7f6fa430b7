"""The desktop's alerts list (issue 30, item 2): an alert the relay raises appears above the findings with a count
badge, and its Acknowledge button sends alert/ack under the page's operator name; the alert then leaves the list."""

from __future__ import annotations

from tests.helpers.browser import SOFTWARE_GL, OpenClient, Station
from tests.helpers.inspection import stored_alert


async def test_an_alert_is_acknowledged_from_the_desktop_list(station: Station, open_client: OpenClient) -> None:
    client = await open_client(f"{station.url}/?{SOFTWARE_GL}", "alerts", 1280, 760, operator="Tess")
    page = client.page
    inspection = station.running.relay.inspection
    alert = inspection.raise_alert(
        "threshold", "Past its limit at Spill (robot1): gas 698.2 ppm (over 400 ppm)", robot="robot1",
        severity="critical",
    )  # fmt: skip
    item = f"#findings li[data-alert='{alert.id}']"
    await page.wait_for_selector(item, timeout=30_000)
    assert await page.inner_text("#findings .badge") == "1"
    assert "gas 698.2 ppm" in await page.inner_text(item)
    await page.click(f"#findings button[data-ack='{alert.id}']")
    await page.wait_for_selector(item, state="detached", timeout=30_000)
    assert await page.locator("#findings .badge").count() == 0
    acknowledged = await stored_alert(station.running, alert.id)
    assert acknowledged is not None and acknowledged.acked_by == "Tess"
